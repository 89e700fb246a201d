"""Procedural textures with detail at the scale a Kinect resolves from 0.5 to 4 m.

Every texture is an ``(h, w, 3)`` uint8 RGB image drawn from an explicit numpy Generator,
so a scene built twice from the same seed is identical. Sizes are given in texels; the
scene builders choose how many metres a texel spans.
"""

import cv2
import numpy as np

_FONTS = (
    cv2.FONT_HERSHEY_SIMPLEX,
    cv2.FONT_HERSHEY_DUPLEX,
    cv2.FONT_HERSHEY_COMPLEX,
    cv2.FONT_HERSHEY_TRIPLEX,
    cv2.FONT_HERSHEY_PLAIN,
)
_LETTERS = np.array(list("ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789abcdefghijklmnopqrstuvwxyz"))


def fractal_noise(
    rng: np.random.Generator,
    height: int,
    width: int,
    coarsest: float = 64.0,
    finest: float = 2.0,
    persistence: float = 0.6,
) -> np.ndarray:
    """Multi-octave value noise in about [-1, 1]: cells halve from ``coarsest`` to ``finest`` texels.

    Each octave is a random grid enlarged with bicubic interpolation; coarse octaves give
    shading, fine ones the corners a feature detector locks onto.
    """
    total = np.zeros((height, width), np.float32)
    amplitude, norm, cell = 1.0, 0.0, max(coarsest, finest)
    while cell >= finest:
        grid = rng.standard_normal((int(height / cell) + 2, int(width / cell) + 2)).astype(np.float32)
        layer = cv2.resize(grid, (int(grid.shape[1] * cell), int(grid.shape[0] * cell)), interpolation=cv2.INTER_CUBIC)
        total += amplitude * layer[:height, :width]
        norm += amplitude**2
        amplitude *= persistence
        cell /= 2.0
    return total / np.float32(np.sqrt(norm) * 2.5)


def plaster(rng, height, width, base=(200, 196, 186), contrast=28.0) -> np.ndarray:
    """Painted wall or concrete: mottled multi-octave noise with dark specks."""
    field = fractal_noise(rng, height, width, coarsest=96, finest=2, persistence=0.7)
    image = np.asarray(base, np.float32) + contrast * field[..., None]
    specks = rng.random((height, width)) < 0.004
    image[specks] *= 0.6
    return np.clip(image, 0, 255).astype(np.uint8)


def wood(rng, height, width, contrast=1.0, knots=None, base=(176, 128, 84)) -> np.ndarray:
    """Wood grain along the texture's x axis: warped rings, fibres and dark knots.

    ``contrast`` scales the grain and ``knots`` the knots (default: as the grain): numbers,
    or ``(h, w)`` maps that fade them locally.
    """
    rows = np.arange(height, dtype=np.float32)[:, None]
    warp = fractal_noise(rng, height, width, coarsest=128, finest=8, persistence=0.5)
    period = rng.uniform(18.0, 30.0)
    rings = np.sin(2 * np.pi * (rows / period + 1.5 * warp)) ** 8
    fibres = fractal_noise(rng, height, width, coarsest=4, finest=1, persistence=0.8)
    fibres = cv2.resize(cv2.resize(fibres, (max(width // 16, 1), height)), (width, height))
    knot_field = np.zeros((height, width), np.float32)
    for _ in range(int(rng.poisson(height * width / 40000.0))):
        centre = (int(rng.integers(width)), int(rng.integers(height)))
        axes = (int(rng.integers(6, 20)), int(rng.integers(3, 8)))
        cv2.ellipse(knot_field, centre, axes, 0.0, 0.0, 360.0, -1.5, -1, cv2.LINE_AA)
        cv2.ellipse(knot_field, centre, (axes[0] + 4, axes[1] + 3), 0.0, 0.0, 360.0, -0.6, 2, cv2.LINE_AA)
    contrast = np.asarray(contrast, np.float32)
    knots = contrast if knots is None else np.asarray(knots, np.float32)
    field = (0.9 * rings - 0.45 + 0.5 * fibres + 0.4 * warp) * contrast + knot_field * knots
    shade = np.asarray(base, np.float32) * (1.0 + 0.35 * field[..., None])
    return np.clip(shade, 0, 255).astype(np.uint8)


def plain(rng, height, width, colour, variation=3.0) -> np.ndarray:
    """An almost uniform surface (cardboard, painted box): only slow, faint shading."""
    field = fractal_noise(rng, height, width, coarsest=max(height, width) / 2, finest=32, persistence=0.5)
    return np.clip(np.asarray(colour, np.float32) + variation * field[..., None], 0, 255).astype(np.uint8)


def fabric(rng, height, width, colour) -> np.ndarray:
    """Clothing: a woven fine noise over a few broad folds."""
    folds = fractal_noise(rng, height, width, coarsest=48, finest=12, persistence=0.5)
    weave = fractal_noise(rng, height, width, coarsest=2, finest=1, persistence=0.5)
    field = 40 * folds + 14 * weave
    return np.clip(np.asarray(colour, np.float32) + field[..., None], 0, 255).astype(np.uint8)


def random_colour(rng, low=0, high=255) -> tuple[int, int, int]:
    red, green, blue = (int(c) for c in rng.integers(low, high, 3))
    return red, green, blue


def random_word(rng, length_range=(3, 9)) -> str:
    return "".join(rng.choice(_LETTERS, int(rng.integers(*length_range))))


def draw_text_lines(rng, image, top, bottom, left, colour, scale) -> None:
    """Fill the rows from ``top`` to ``bottom`` with lines of random words (clipped at the border)."""
    font = _FONTS[int(rng.integers(len(_FONTS)))]
    (_, line_height), _ = cv2.getTextSize("Ag", font, scale, 1)
    y = top + line_height
    while y < bottom:
        text = " ".join(random_word(rng) for _ in range(8))
        cv2.putText(image, text, (left, y), font, scale, colour, max(1, int(scale * 1.5)), cv2.LINE_AA)
        y += int(line_height * 1.8)


def poster(rng, height, width) -> np.ndarray:
    """A poster: coloured background, bold shapes, a headline and paragraphs of text.

    High contrast at several sizes, unique per draw: discriminative for loop closure.
    """
    background = random_colour(rng, 120, 255)
    image = np.empty((height, width, 3), np.uint8)
    image[:] = background
    scale = min(height, width)
    for _ in range(int(rng.integers(6, 14))):
        colour = random_colour(rng)
        kind = rng.integers(4)
        centre = (int(rng.integers(0, width)), int(rng.integers(0, height)))
        size = int(rng.uniform(0.04, 0.25) * scale)
        thickness = -1 if rng.random() < 0.6 else int(rng.integers(2, 8))
        if kind == 0:
            cv2.circle(image, centre, size, colour, thickness, cv2.LINE_AA)
        elif kind == 1:
            corner = (centre[0] + size, centre[1] + int(size * rng.uniform(0.4, 1.6)))
            cv2.rectangle(image, centre, corner, colour, thickness, cv2.LINE_AA)
        elif kind == 2:
            points = rng.integers(-size, size, (int(rng.integers(3, 6)), 2)) + np.array(centre)
            cv2.fillPoly(image, [points.astype(np.int32)], colour, cv2.LINE_AA)
        else:
            points = rng.integers(-size, size, (int(rng.integers(3, 7)), 2)) + np.array(centre)
            cv2.polylines(image, [points.astype(np.int32)], False, colour, int(rng.integers(2, 6)), cv2.LINE_AA)
    ink = (20, 20, 20) if sum(background) > 380 else (245, 245, 245)
    font = _FONTS[int(rng.integers(len(_FONTS)))]
    cv2.putText(
        image,
        random_word(rng, (4, 8)).upper(),
        (int(0.06 * width), int(0.14 * height)),
        font,
        scale / 180.0,
        ink,
        max(2, scale // 90),
        cv2.LINE_AA,
    )
    draw_text_lines(rng, image, int(0.7 * height), int(0.95 * height), int(0.06 * width), ink, scale / 500.0)
    cv2.rectangle(image, (0, 0), (width - 1, height - 1), random_colour(rng, 0, 90), max(2, scale // 100))
    return image


def page(rng, height, width) -> np.ndarray:
    """A printed sheet of paper: white with dense text lines."""
    image = np.full((height, width, 3), 242, np.uint8)
    draw_text_lines(
        rng, image, int(0.06 * height), int(0.94 * height), int(0.06 * width), (30, 30, 30), min(height, width) / 420.0
    )
    return image


def bookshelf_row(rng, height, width) -> np.ndarray:
    """Book spines of random colour and width, each with a title and bands."""
    image = np.empty((height, width, 3), np.uint8)
    image[:] = (60, 45, 35)
    x = 0
    while x < width:
        spine = int(rng.integers(max(width // 40, 6), max(width // 12, 8)))
        top = int(rng.integers(0, height // 4))
        colour = random_colour(rng, 20, 230)
        cv2.rectangle(image, (x, top), (x + spine - 2, height - 1), colour, -1)
        band = random_colour(rng)
        for y in rng.integers(top, height, 2):
            cv2.rectangle(image, (x, int(y)), (x + spine - 2, int(y) + max(2, spine // 6)), band, -1)
        label = random_word(rng, (2, 5))
        cv2.putText(
            image,
            label,
            (x + 1, top + height // 3),
            cv2.FONT_HERSHEY_PLAIN,
            spine / 40.0,
            (250, 250, 250) if sum(colour) < 380 else (10, 10, 10),
            1,
            cv2.LINE_AA,
        )
        x += spine
    return image


def bookcase(rng, height, width, shelves=5) -> np.ndarray:
    """The front of a bookcase: shelves of book rows between wooden boards."""
    image = np.empty((height, width, 3), np.uint8)
    image[:] = (120, 84, 52)
    board = max(height // 40, 3)
    row_height = height // shelves
    for k in range(shelves):
        top = k * row_height + board
        image[top : (k + 1) * row_height] = bookshelf_row(rng, (k + 1) * row_height - top, width)
    return image


def keyboard(rng, height, width) -> np.ndarray:
    """Rows of keys with letters: a dense grid of corners, as on a real desk."""
    if height > width:  # a keyboard lying across the texture's rows
        return np.ascontiguousarray(np.rot90(keyboard(rng, width, height)))
    image = np.full((height, width, 3), 40, np.uint8)
    rows, cols = 5, 14
    key_w, key_h = width / cols, height / rows
    for r in range(rows):
        for c in range(cols):
            x0, y0 = int(c * key_w + 2), int(r * key_h + 2)
            x1, y1 = int((c + 1) * key_w - 2), int((r + 1) * key_h - 2)
            cv2.rectangle(image, (x0, y0), (x1, y1), (200, 200, 196), -1)
            cv2.putText(
                image,
                str(rng.choice(_LETTERS)).upper(),
                (x0 + 2, y1 - 3),
                cv2.FONT_HERSHEY_PLAIN,
                key_h / 28.0,
                (20, 20, 20),
                1,
                cv2.LINE_AA,
            )
    return image


def screen(rng, height, width) -> np.ndarray:
    """A monitor showing windows with text and a chart."""
    image = np.full((height, width, 3), random_colour(rng, 20, 80), np.uint8)
    for _ in range(3):
        w, h = int(rng.integers(width // 4, width // 2)), int(rng.integers(height // 4, height // 2))
        x0, y0 = int(rng.integers(0, width - w)), int(rng.integers(0, height - h))
        window = np.full((h, w, 3), 235, np.uint8)
        window[:12] = random_colour(rng, 0, 200)
        draw_text_lines(rng, window, 14, h - 2, 4, (25, 25, 25), 0.3)
        image[y0 : y0 + h, x0 : x0 + w] = window
    return image


def checker_mat(rng, height, width) -> np.ndarray:
    """A patterned rug: checker tiles of noise-tinted colours."""
    tile = int(rng.integers(24, 48))
    rows, cols = np.indices((height, width)) // tile
    colours = np.array([random_colour(rng, 40, 220) for _ in range(4)], np.float32)
    image = colours[(rows + 2 * cols) % 4]
    image += 18 * fractal_noise(rng, height, width, coarsest=8, finest=1)[..., None]
    return np.clip(image, 0, 255).astype(np.uint8)
