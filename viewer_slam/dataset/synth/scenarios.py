"""The seven situations of the study, each a scene, a camera path and its events.

Paths are laid out over the run's duration (``frames / 30`` s), so every event (covering,
the featureless stretch, the loop) happens in any run of at least 100 frames; at the
default length the motion has the speed of the TUM sequence it mirrors (hand-held at most
~0.4 m/s and ~40 deg/s, the robot slower).
"""

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from . import textures
from .catalog import SCENARIO_INFO, ScenarioInfo
from .scenes import (
    Mover,
    Scene,
    Surface,
    box,
    cylinder,
    desk,
    person_parts,
    quad,
    room,
    transformed,
    wall_poster,
    yaw_pose,
)
from .trajectories import CAMERA_RATE, Path, Tremor, look_angles

TAU = 2 * np.pi


@dataclass(frozen=True)
class Plan:
    """Everything needed to render one run of a scenario."""

    scene: Scene
    path: Path
    covered: list[tuple[int, int]]  # first and last covered frame index, inclusive
    loop: bool
    exposure: float  # seconds of motion blur; 0 for none
    notes: str


@dataclass(frozen=True)
class Scenario:
    """A scenario's description and the function that plans its run."""

    info: ScenarioInfo
    build: Callable[[np.random.Generator, int], Plan]

    @property
    def name(self) -> str:
        return self.info.name

    @property
    def default_frames(self) -> int:
        return self.info.default_frames


def _cloth(colour):
    return lambda rng, h, w: textures.fabric(rng, h, w, colour)


def _flat(colour, variation=3.0):
    return lambda rng, h, w: textures.plain(rng, h, w, colour, variation)


def _wall(rng, h, w):
    return textures.plaster(rng, h, w, base=tuple(int(c) for c in rng.integers(170, 225, 3)))


def _smoothstep(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


def walls(size) -> dict[str, tuple]:
    """The walls of a room with a corner at the origin: start ``(x, y)``, run ``(dx, dy)`` and
    the yaw of the normal pointing into the room."""
    w, d, _ = size
    return {
        "south": ((0.0, 0.0), (w, 0.0), np.pi / 2),
        "north": ((w, d), (-w, 0.0), -np.pi / 2),
        "west": ((0.0, d), (0.0, -d), 0.0),
        "east": ((w, 0.0), (0.0, d), np.pi),
    }


def decorated_room(rng, size, poster_density=0.7, bookcases=2) -> list[Surface]:
    """A room with plaster walls, posters at eye height, bookcases and a checkered rug."""
    w, d, h = size
    surfaces = room(
        rng,
        size,
        _wall,
        lambda r, hh, ww: textures.plaster(r, hh, ww, (140, 130, 120), 40),
        _flat((235, 235, 230), 2.0),
        texel=0.005,
        floor_texel=0.006,
    )
    shelves_left = bookcases
    for (x0, y0), (dx, dy), normal_yaw in walls(size).values():
        length = np.hypot(dx, dy)
        direction = np.array([dx, dy]) / length
        for along in np.arange(0.7, length - 0.6, 1.15):
            roll = rng.random()
            base = np.array([x0, y0]) + direction * along
            if shelves_left and roll < 0.15:
                shelves_left -= 1
                inward = np.array([np.cos(normal_yaw), np.sin(normal_yaw)])
                centre = base + inward * 0.18
                surfaces += box(rng, (*centre, 0.9), (0.9, 0.34, 1.8), textures.wood, 0.003, yaw=normal_yaw - np.pi / 2)
                front = wall_poster(
                    rng, (*(base + inward * 0.35), 0.9), normal_yaw, 0.86, 1.76, texel=0.002, painter=textures.bookcase
                )
                surfaces.append(front)
            elif roll < poster_density:
                width, height = rng.uniform(0.5, 0.9), rng.uniform(0.6, 1.0)
                surfaces.append(wall_poster(rng, (*base, rng.uniform(1.2, 1.6)), normal_yaw, width, height))
    rug = (rng.uniform(1.0, w - 3.0), rng.uniform(1.0, d - 3.0))
    surfaces.append(quad(rng, (*rug, 0.004), (2.0, 0, 0), (0, 1.4, 0), textures.checker_mat, 0.004))
    return surfaces


def cluttered_desk(rng, corner, facing_yaw: float, size=(1.6, 0.8, 0.74)) -> list[Surface]:
    """A desk and what stands on it."""
    return desk(rng, corner, size) + desk_clutter(rng, corner, size, facing_yaw)


def desk_frame(corner, size, facing_yaw: float):
    """Where things stand on a desk, in the frame of the user who looks along ``facing_yaw``:
    ``at(along, across)`` maps -1..1 along the desk's depth and width to world x, y; with the
    forward and sideways unit vectors."""
    x, y, _ = corner
    w, d, _ = size
    c, s = np.cos(facing_yaw), np.sin(facing_yaw)
    centre = np.array([x + w / 2, y + d / 2])
    forward, side = np.array([c, s]), np.array([-s, c])

    def at(along, across):
        return centre + forward * along * d / 2 + side * across * w / 2

    return at, forward, side


def desk_clutter(rng, corner, size, facing_yaw: float) -> list[Surface]:
    """A monitor, keyboard, papers, books and mugs on a desk whose user looks along ``facing_yaw``."""
    top = size[2]
    at, forward, _ = desk_frame(corner, size, facing_yaw)
    surfaces = box(rng, (*at(0.6, -0.3), top + 0.25), (0.05, 0.55, 0.34), _flat((30, 30, 32)), 0.003, yaw=facing_yaw)
    screen_centre = at(0.6, -0.3) - forward * 0.03
    surfaces.append(
        wall_poster(
            rng, (*screen_centre, top + 0.26), facing_yaw + np.pi, 0.5, 0.3, texel=0.001, painter=textures.screen
        )
    )
    surfaces += box(rng, (*at(0.55, -0.3), top + 0.04), (0.2, 0.25, 0.08), _flat((40, 40, 45)), 0.004, yaw=facing_yaw)
    surfaces += box(
        rng,
        (*at(-0.35, -0.3), top + 0.012),
        (0.16, 0.45, 0.024),
        _flat((40, 40, 40)),
        0.002,
        yaw=facing_yaw,
        top=textures.keyboard,
    )
    for _ in range(3):
        corner_xy = at(rng.uniform(-0.8, 0.2), rng.uniform(0.1, 0.7))
        angle = facing_yaw + rng.uniform(-0.4, 0.4)
        u = 0.3 * np.array([np.cos(angle), np.sin(angle), 0.0])
        v = 0.21 * np.array([np.sin(angle), -np.cos(angle), 0.0])
        surfaces.append(quad(rng, (*corner_xy, top + 0.002), u, v, textures.page, 0.0008))
    books = at(0.5, 0.7)
    for k in range(int(rng.integers(2, 5))):
        thickness = rng.uniform(0.02, 0.05)
        surfaces += box(
            rng,
            (*books, top + 0.015 + 0.05 * k),
            (0.24, 0.17, thickness),
            textures.bookshelf_row,
            0.001,
            yaw=facing_yaw + rng.uniform(-0.3, 0.3),
            top=textures.poster,
        )
    for _ in range(2):
        surfaces += cylinder(
            rng, (*at(rng.uniform(-0.6, 0.3), rng.uniform(-0.9, 0.9)), top), 0.04, 0.1, textures.poster, 0.001
        )
    return surfaces


def household_desk(rng, corner, facing_yaw: float, size=(1.6, 0.8, 0.74)) -> list[Surface]:
    """A desk and the household things on it."""
    return desk(rng, corner, size) + household_clutter(rng, corner, size, facing_yaw)


def household_clutter(rng, corner, size, facing_yaw: float) -> list[Surface]:
    """A potted plant, a table lamp, a fruit bowl, food boxes, a teddy bear and magazines on a
    table cloth: the household side of a desk pair. Nothing on it repeats the office desk's
    monitor, keyboard or book stack, so that the two desks, set back to back, do not look
    alike from opposite sides of the room (as the real sequence's two desks do not)."""
    top = size[2]
    at, forward, side = desk_frame(corner, size, facing_yaw)
    cloth_corner = at(-0.9, -0.55)
    surfaces = [
        quad(
            rng,
            (*cloth_corner, top + 0.001),
            (*(side * 0.9), 0.0),
            (*(forward * 0.65), 0.0),
            _cloth((170, 40, 45)),
            0.002,
        )
    ]
    surfaces += cylinder(rng, (*at(0.45, 0.75), top), 0.09, 0.16, _cloth((170, 90, 50)), 0.002)
    surfaces += cylinder(rng, (*at(0.45, 0.75), top + 0.16), 0.16, 0.28, _cloth((40, 110, 40)), 0.003)
    surfaces += cylinder(rng, (*at(0.6, -0.85), top), 0.07, 0.3, _flat((200, 190, 160), 6.0), 0.002)
    surfaces += cylinder(rng, (*at(0.6, -0.85), top + 0.3), 0.14, 0.16, _cloth((230, 210, 150)), 0.002)
    surfaces += cylinder(rng, (*at(-0.3, -0.2), top), 0.14, 0.07, _flat((235, 235, 225), 4.0), 0.002)
    for _ in range(4):
        fruit = at(-0.3, -0.2) + rng.uniform(-0.06, 0.06, 2)
        surfaces += cylinder(
            rng, (*fruit, top + 0.07), 0.035, 0.05, _flat(textures.random_colour(rng, 60, 230), 8.0), 0.002
        )
    for k in range(2):
        surfaces += box(
            rng,
            (*at(0.55, -0.35 + 0.22 * k), top + 0.15),
            (0.07, 0.19, 0.3),
            textures.poster,
            0.001,
            yaw=facing_yaw + rng.uniform(-0.2, 0.2),
        )
    teddy = at(0.1, 0.3)
    surfaces += box(rng, (*teddy, top + 0.09), (0.12, 0.16, 0.18), _cloth((140, 95, 55)), 0.002, yaw=facing_yaw)
    surfaces += cylinder(rng, (*teddy, top + 0.18), 0.07, 0.12, _cloth((150, 105, 60)), 0.002)
    for _ in range(2):
        corner_xy = at(rng.uniform(-0.6, -0.2), rng.uniform(0.5, 0.8))
        angle = facing_yaw + rng.uniform(-0.8, 0.8)
        u = 0.22 * np.array([np.cos(angle), np.sin(angle), 0.0])
        v = 0.28 * np.array([np.sin(angle), -np.cos(angle), 0.0])
        surfaces.append(quad(rng, (*corner_xy, top + 0.003), u, v, textures.poster, 0.0008))
    return surfaces


def seated_person(
    rng, base: np.ndarray, sway: Callable, lift: Callable, shirt, trousers
) -> tuple[list[Surface], list[Mover]]:
    """A person on a stool at ``base`` (4x4) whose torso turns by ``sway(t)`` and whose arms lift by
    ``lift(t, side)``: the legs and stool are static surfaces, the torso and arms movers."""
    parts = person_parts(rng, shirt, trousers)
    stool = box(rng, (-0.05, 0, 0.2), (0.45, 0.45, 0.4), _flat((60, 60, 70), 6), 0.005)
    static = transformed(parts["legs"] + stool, base)

    def torso_pose(t: float) -> np.ndarray:
        return base @ yaw_pose(0, 0, 0, sway(t))

    movers = [Mover(parts["torso"], torso_pose)]
    for side, (offset, arm) in enumerate(zip((-0.26, 0.26), parts["arms"])):

        def arm_pose(t: float, side: int = side, offset: float = offset) -> np.ndarray:
            return torso_pose(t) @ yaw_pose(0.0, offset, 1.08, 0.0, -lift(t, side))

        movers.append(Mover(arm, arm_pose))
    return static, movers


def _ceiling_lights(size):
    w, d, h = size
    return tuple((x, y, h - 0.1) for x in (w / 3, 2 * w / 3) for y in (d / 3, 2 * d / 3))


def keyframes_along(times, positions, targets) -> np.ndarray:
    """Keyframe rows ``(t, x, y, z, yaw, pitch, roll = 0)`` looking from each position at its target."""
    rows = []
    yaw_prev = None
    for t, p, g in zip(times, positions, targets):
        yaw, pitch = look_angles(p, g)
        if yaw_prev is not None:  # unwrap, so the camera turns the short way
            yaw = yaw_prev + (yaw - yaw_prev + np.pi) % TAU - np.pi
        yaw_prev = yaw
        rows.append([t, *p, yaw, pitch, 0.0])
    return np.array(rows)


# --- scenarios ------------------------------------------------------------------------------


def build_desk_with_person(rng, frames) -> Plan:
    size = (5.0, 4.5, 2.7)
    scene = Scene(lights=_ceiling_lights(size))
    scene.add(decorated_room(rng, size, poster_density=0.8))
    scene.add(cluttered_desk(rng, (1.7, 2.4, 0.0), facing_yaw=np.pi / 2))
    duration = frames / CAMERA_RATE
    shift_start, shift_end = 0.4 * duration, 0.55 * duration

    def lift(t, side):
        reach = np.sin(np.pi * np.clip((t - shift_start + 1.0) / (shift_end - shift_start + 2.0), 0, 1))
        return (1.1 * reach if side == 0 else 0.0) + 0.15 * np.sin(1.3 * t + side)

    static, movers = seated_person(
        rng,
        yaw_pose(2.4, 3.75, 0.0, -np.pi / 2),
        lambda t: 0.25 * np.sin(0.7 * t),
        lift,
        shirt=(70, 90, 160),
        trousers=(50, 50, 60),
    )
    scene.add(static)
    scene.movers.extend(movers)
    shifted = box(rng, (0, 0, 0.06), (0.15, 0.1, 0.12), textures.poster, 0.001)

    def shifted_pose(t):
        s = _smoothstep((t - shift_start) / (shift_end - shift_start))
        return yaw_pose(2.05 + 0.3 * s, 2.75 + 0.15 * s, 0.74, 0.6 * s)

    scene.movers.append(Mover(shifted, shifted_pose))
    centre = np.array([2.5, 2.8])
    arc = np.radians([0, -35, -10, 30, 10, 0])
    heights = [1.45, 1.35, 1.55, 1.4, 1.5, 1.45]
    radii = [1.6, 1.4, 1.7, 1.5, 1.6, 1.6]
    positions = [(*(centre + r * np.array([np.sin(a), -np.cos(a)])), z) for a, r, z in zip(arc, radii, heights)]
    targets = [(*(centre + rng.uniform(-0.25, 0.25, 2)), 0.85) for _ in arc]
    targets[-1] = targets[0]
    times = np.linspace(0, duration, len(arc))
    path = Path(keyframes_along(times, positions, targets), Tremor(rng, 0.004, np.radians(0.5)))
    return Plan(
        scene,
        path,
        [],
        True,
        0.012,
        "person sways and moves an arm throughout; moves a box on the desk between "
        f"{shift_start:.1f} s and {shift_end:.1f} s; camera returns to its start",
    )


def build_sitting_static(rng, frames) -> Plan:
    size = (5.0, 4.5, 2.7)
    scene = Scene(lights=_ceiling_lights(size))
    scene.add(decorated_room(rng, size, poster_density=0.8))
    scene.add(cluttered_desk(rng, (1.7, 2.3, 0.0), facing_yaw=np.pi / 2))
    for x, shirt, phase in ((2.1, (160, 60, 60), 0.0), (2.95, (60, 140, 90), 1.7)):
        frequency = rng.uniform(0.35, 0.6)

        def lift(t, side, f=frequency, p=phase):
            return 0.5 + 0.45 * np.sin(TAU * f * t + p + 1.3 * side)

        static, movers = seated_person(
            rng,
            yaw_pose(x, 3.6, 0.0, -np.pi / 2),
            lambda t, p=phase: 0.2 * np.sin(0.9 * t + p),
            lift,
            shirt=shirt,
            trousers=(45, 45, 55),
        )
        scene.add(static)
        scene.movers.extend(movers)
    duration = frames / CAMERA_RATE
    position, target = (2.5, 1.0, 1.3), (2.5, 3.2, 0.85)
    path = Path(
        keyframes_along([0.0, duration], [position, position], [target, target]), Tremor(rng, 0.002, np.radians(0.25))
    )
    return Plan(scene, path, [], False, 0.008, "two seated people gesture; the camera only trembles")


def hall(rng, size, poster_walls) -> list[Surface]:
    """A large hall: concrete walls, a grey floor, posters only on the walls listed."""
    concrete = lambda r, hh, ww: textures.plaster(r, hh, ww, (165, 165, 160), 22)  # noqa: E731
    surfaces = room(
        rng,
        size,
        concrete,
        lambda r, hh, ww: textures.plaster(r, hh, ww, (120, 120, 118), 30),
        _flat((200, 200, 200), 2.0),
        texel=0.006,
        floor_texel=0.01,
    )
    for name in poster_walls:
        (x0, y0), (dx, dy), normal_yaw = walls(size)[name]
        length = np.hypot(dx, dy)
        for along in np.arange(1.0, length - 0.8, 1.3):
            if rng.random() < 0.6:
                base = np.array([x0, y0]) + np.array([dx, dy]) / length * along
                surfaces.append(
                    wall_poster(
                        rng, (*base, rng.uniform(1.0, 1.6)), normal_yaw, rng.uniform(0.6, 1.0), rng.uniform(0.7, 1.1)
                    )
                )
    return surfaces


def plain_boxes(rng, centre, count, keep_out: float, spread: float) -> list[Surface]:
    """Cardboard boxes scattered around ``centre`` outside a radius ``keep_out``: little texture."""
    surfaces = []
    for _ in range(count):
        angle, radius = rng.uniform(0, TAU), rng.uniform(keep_out, spread)
        size = rng.uniform([0.3, 0.3, 0.3], [0.8, 0.6, 0.9])
        position = np.asarray(centre) + radius * np.array([np.cos(angle), np.sin(angle)])
        colour = tuple(int(c) for c in rng.integers([150, 110, 70], [200, 150, 100]))
        surfaces += box(rng, (*position, size[2] / 2), size, _flat(colour, 4.0), 0.006, yaw=rng.uniform(0, np.pi))
    return surfaces


def build_pioneer_360(rng, frames) -> Plan:
    size = (16.0, 12.0, 4.0)
    centre, radius = np.array([4.5, 4.0]), 1.2
    scene = Scene(lights=((4.0, 3.0, 3.8), (10.0, 8.0, 3.8), (4.0, 9.0, 3.8), (12.0, 3.0, 3.8)), ambient=0.45)
    scene.add(hall(rng, size, poster_walls=("south", "west")))
    scene.add(plain_boxes(rng, centre, 10, keep_out=radius + 1.5, spread=4.5))
    duration = frames / CAMERA_RATE
    heading = np.linspace(0.0, TAU, 13) + rng.uniform(-0.2, 0.2)
    times = np.linspace(0, duration, len(heading))
    keyframes = np.array(
        [
            [t, *(centre + radius * np.array([np.sin(a), -np.cos(a)])), 0.45, a, -0.03, 0.0]
            for t, a in zip(times, heading)
        ]
    )
    path = Path(keyframes, Tremor(rng, 0.002, np.radians(0.3)))
    return Plan(
        scene,
        path,
        [],
        True,
        0.008,
        "planar robot drive on a 1.2 m circle, one full turn; the north and east walls lie "
        "beyond the 4.5 m depth range, the boxes are plain cardboard",
    )


def kidnap_segments(frames, revisit: bool) -> tuple[list[tuple], int]:
    """Visible sweeps ``(yaw_from, yaw_to, start_xy, end_xy)`` (degrees, metres) and the covered length.

    Three coverings from 300 frames, two from 20 (none in shorter runs). Each covering turns
    the view by at least 100 degrees and moves the camera by half a metre or more, so
    nothing seen just before it is in view just after. With ``revisit``, as in the real
    fr2/360_kidnap, every sweep after a covering starts on walls not seen before and turns
    back onto the first sweep's view, so a method can re-localise there. Without it, the
    sweeps' fields of view (about 58 degrees across) never overlap: nothing mapped before a
    covering is seen again. Walls stay within depth range from every place.
    """
    covered = max(8, int(round(0.06 * frames))) if frames >= 100 else max(1, int(round(0.08 * frames)))
    if frames < 20:
        return [(0, 90, (3.2, 2.8), (3.5, 3.0))], 0
    if revisit:
        first = (0, 50, (3.2, 2.8), (3.5, 3.0))
        if frames >= 300:
            return [
                first,
                (160, 20, (4.1, 3.4), (3.8, 3.6)),
                (250, 390, (3.5, 2.3), (3.8, 2.5)),
                (260, 400, (3.3, 2.9), (3.7, 3.2)),
            ], covered
        return [first, (160, 20, (4.1, 3.4), (3.8, 3.6)), (250, 400, (3.3, 2.9), (3.7, 3.2))], covered
    if frames >= 300:
        return [
            (0, 20, (3.2, 2.8), (3.5, 3.0)),
            (90, 110, (4.1, 3.4), (3.8, 3.6)),
            (180, 200, (3.5, 2.3), (3.8, 2.5)),
            (270, 290, (3.3, 2.9), (3.7, 3.2)),
        ], covered
    return [
        (0, 45, (3.2, 2.8), (3.5, 3.0)),
        (125, 170, (4.1, 3.4), (3.8, 3.6)),
        (225, 270, (3.3, 2.9), (3.7, 3.2)),
    ], covered


def build_360_kidnap(rng, frames, revisit: bool = True) -> Plan:
    size = (7.0, 6.0, 3.0)
    scene = Scene(lights=_ceiling_lights(size))
    scene.add(decorated_room(rng, size, poster_density=0.85, bookcases=3))
    scene.add(cluttered_desk(rng, (4.9, 0.4, 0.0), facing_yaw=-np.pi / 2))
    scene.add(plain_boxes(rng, (3.5, 3.0), 4, keep_out=1.9, spread=2.6))
    segments, covered_length = kidnap_segments(frames, revisit)
    visible = frames - covered_length * (len(segments) - 1)
    sweeps = np.array([abs(b - a) for a, b, _, _ in segments], float)
    lengths = np.floor(visible * sweeps / sweeps.sum()).astype(int)
    lengths[-1] += visible - lengths.sum()
    keyframes, covered, frame = [], [], 0
    for k, ((yaw0, yaw1, p0, p1), length) in enumerate(zip(segments, lengths)):
        for s in (0.0, 0.5, 1.0) if length > 1 else (0.0,):
            t = (frame + s * (length - 1)) / CAMERA_RATE
            xy = np.asarray(p0) + s * (np.asarray(p1) - np.asarray(p0))
            pitch = np.radians(8 + 4 * np.sin(3 * k + 2 * s))
            keyframes.append([t, *xy, 1.3 + 0.05 * np.sin(k + s), np.radians(yaw0 + s * (yaw1 - yaw0)), pitch, 0.0])
        frame += length
        if k < len(segments) - 1:
            covered.append((frame, frame + covered_length - 1))
            frame += covered_length
    path = Path(keyframes, Tremor(rng, 0.003, np.radians(0.4)))
    seen_again = (
        "each sweep after a covering starts on unseen walls and turns back onto the first sweep's view"
        if revisit
        else "no view of before a covering is seen again"
    )
    return Plan(
        scene,
        path,
        covered,
        revisit,
        0.012,
        f"sensor covered {len(covered)} times for {covered_length} frames while the camera is carried "
        f"elsewhere (view turned by 100 degrees or more); {seen_again}",
    )


def build_360_kidnap_norevisit(rng, frames) -> Plan:
    return build_360_kidnap(rng, frames, revisit=False)


def build_long_office_household(rng, frames) -> Plan:
    size = (8.0, 7.0, 2.8)
    scene = Scene(lights=_ceiling_lights(size))
    scene.add(decorated_room(rng, size, poster_density=0.8, bookcases=3))
    centre = np.array([4.0, 3.5])
    scene.add(cluttered_desk(rng, (3.2, 2.7, 0.0), facing_yaw=-np.pi / 2))
    scene.add(household_desk(rng, (3.2, 3.5, 0.0), facing_yaw=np.pi / 2))
    scene.add(cylinder(rng, (7.4, 6.4, 0.0), 0.18, 0.5, _cloth((150, 100, 60)), 0.004))
    scene.add(cylinder(rng, (7.4, 6.4, 0.5), 0.3, 0.5, _cloth((50, 120, 40)), 0.004))
    scene.add(box(rng, (0.6, 6.3, 0.25), (0.3, 0.25, 0.5), _cloth((140, 100, 60)), 0.003))
    duration = frames / CAMERA_RATE
    start = rng.uniform(0, TAU)
    angles = start + np.linspace(0.0, TAU + np.radians(40), 21)
    radii = 2.0 + 0.2 * np.sin(3 * angles)
    positions = [
        (*(centre + r * np.array([np.cos(a), np.sin(a)])), 1.5 + 0.08 * np.sin(2 * a)) for a, r in zip(angles, radii)
    ]
    targets = [(*(centre + 0.25 * np.array([np.cos(2 * a), np.sin(3 * a)])), 0.8) for a in angles]
    path = Path(
        keyframes_along(np.linspace(0, duration, len(angles)), positions, targets), Tremor(rng, 0.004, np.radians(0.5))
    )
    return Plan(
        scene,
        path,
        [],
        True,
        0.012,
        "one round about two desks of office and household clutter; the last 40 degrees repeat the start",
    )


NEAR_HEIGHT, NEAR_PITCH = 0.8, np.radians(55)
FEATURELESS_FROM_X = 1.9
FAINT_GRAIN = 0.2  # wood-grain contrast of the texture-less plane (1 = ordinary wood)
KNOTS = 0.5  # and of its sparse knots: the few corners a feature tracker finds there


def near_plane_path(rng, frames) -> Path:
    """An elongated loop 0.8 m above the plane, looking ahead and down, ending over the start.

    The loop's far end (x > 1.75 m) shows only ground beyond ``FEATURELESS_FROM_X``: about
    a quarter of the run, in its middle.
    """
    duration = frames / CAMERA_RATE
    theta = np.pi + np.linspace(0.0, TAU + np.radians(40), 28)
    times = np.linspace(0, duration, len(theta))
    keyframes = np.stack(
        [
            times,
            1.0 + 1.2 * np.cos(theta),
            0.45 * np.sin(theta),
            NEAR_HEIGHT + 0.05 * np.sin(2 * theta),
            np.radians(12) * np.sin(theta + 0.5),
            np.full_like(theta, NEAR_PITCH) + np.radians(4) * np.cos(3 * theta),
            np.radians(3) * np.sin(2 * theta),
        ],
        axis=1,
    )
    return Path(keyframes, Tremor(rng, 0.003, np.radians(0.4)))


def floor_tiles(rng, contrast: Callable[[np.ndarray], np.ndarray], knot_gain=1.0, tile=1.5) -> list[Surface]:
    """Wooden floor in tiles; ``contrast(x)`` sets the grain strength at world ``x`` (metres),
    and knots are ``knot_gain`` times as strong (at most ordinary)."""
    surfaces = []
    for x0 in np.arange(-2.5, 5.0, tile):
        for y0 in np.arange(-3.0, 3.0, tile):

            def painter(r, h, w, x0=x0):
                grain = np.broadcast_to(contrast(x0 + (np.arange(w) + 0.5) / w * tile)[None, :], (h, w))
                return textures.wood(r, h, w, contrast=grain, knots=np.minimum(grain * knot_gain, 1.0))

            surfaces.append(quad(rng, (x0, y0, 0.0), (tile, 0, 0), (0, tile, 0), painter, 0.003))
    return surfaces


def build_nostructure_notexture(rng, frames) -> Plan:
    scene = Scene(lights=((0.0, 0.0, 2.5), (2.5, 0.0, 2.5)), ambient=0.55)
    faint = lambda x: FAINT_GRAIN * (1.0 - _smoothstep((x - FEATURELESS_FROM_X + 0.3) / 0.3))  # noqa: E731
    scene.add(floor_tiles(rng, faint, knot_gain=KNOTS / FAINT_GRAIN))
    return Plan(
        scene,
        near_plane_path(rng, frames),
        [],
        True,
        0.012,
        f"faint wood grain; beyond x = {FEATURELESS_FROM_X} m the plane is uniform, seen alone "
        "for about a quarter of the run, in its middle",
    )


def build_nostructure_texture(rng, frames) -> Plan:
    scene = Scene(lights=((0.0, 0.0, 2.5), (2.5, 0.0, 2.5)), ambient=0.55)
    scene.add(floor_tiles(rng, lambda x: np.full_like(x, 0.8)))
    for x0 in np.arange(-1.2, 4.4, 0.64):
        for y0 in np.arange(-1.9, 1.9, 0.5):
            scene.add([quad(rng, (x0, y0 + 0.46, 0.002), (0.6, 0, 0), (0, -0.46, 0), textures.poster, 0.0015)])
    return Plan(scene, near_plane_path(rng, frames), [], True, 0.012, "posters cover the plane")


BUILDERS: dict[str, Callable[[np.random.Generator, int], Plan]] = {
    "desk_with_person": build_desk_with_person,
    "pioneer_360": build_pioneer_360,
    "360_kidnap": build_360_kidnap,
    "360_kidnap_norevisit": build_360_kidnap_norevisit,
    "long_office_household": build_long_office_household,
    "nostructure_notexture_near_withloop": build_nostructure_notexture,
    "nostructure_texture_near_withloop": build_nostructure_texture,
    "sitting_static": build_sitting_static,
}
SCENARIOS_BY_NAME = {name: Scenario(info, BUILDERS[name]) for name, info in SCENARIO_INFO.items()}
