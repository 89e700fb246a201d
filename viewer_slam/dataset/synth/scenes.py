"""Scenes as textured triangle meshes: quads, boxes, cylinders and people built from them.

World frame: z up, metres. A :class:`Surface` is one textured mesh whose vertices carry
texture coordinates in [0, 1]; ``texel`` (metres per texel) lets the renderer choose the
texture detail a pixel sees. Moving things (people, a shifted object) are
:class:`Mover` s: surfaces in their own frame plus a pose as a function of time.
"""

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TypedDict

import numpy as np
from scipy.spatial.transform import Rotation

from ...geometry.se3 import make_pose
from . import textures

# Largest side of a texture in texels; larger surfaces get coarser texels.
MAX_TEXTURE_SIDE = 2048


@dataclass(frozen=True)
class Surface:
    vertices: np.ndarray  # (V, 3) float64
    triangles: np.ndarray  # (T, 3) int
    uvs: np.ndarray  # (V, 2) texture coordinates in [0, 1]: u along columns, v along rows
    texture: np.ndarray  # (h, w, 3) uint8 RGB
    texel: float  # metres per texel


@dataclass(frozen=True)
class Mover:
    """Surfaces in the object's frame and ``pose(t) -> 4x4`` (object to world) at time ``t``."""

    surfaces: list[Surface]
    pose: Callable[[float], np.ndarray]


@dataclass
class Scene:
    static: list[Surface] = field(default_factory=list)
    movers: list[Mover] = field(default_factory=list)
    lights: tuple[tuple[float, float, float], ...] = ((0.0, 0.0, 2.5),)
    ambient: float = 0.35
    background: tuple[int, int, int] = (0, 0, 0)

    def add(self, surfaces: Sequence[Surface]) -> None:
        self.static.extend(surfaces)


Painter = Callable[[np.random.Generator, int, int], np.ndarray]


def texture_size(extent_u: float, extent_v: float, texel: float) -> tuple[int, int, float]:
    """Texture width and height in texels for a face, and the texel size actually used."""
    texel = max(texel, max(extent_u, extent_v) / MAX_TEXTURE_SIDE)
    return max(int(round(extent_u / texel)), 4), max(int(round(extent_v / texel)), 4), texel


def quad(rng, corner, edge_u, edge_v, painter: Painter, texel: float) -> Surface:
    """A rectangle from ``corner`` spanned by ``edge_u`` (texture columns) and ``edge_v`` (rows).

    The texture reads the right way from the side that ``edge_v x edge_u`` points to.
    """
    corner, edge_u, edge_v = (np.asarray(a, np.float64) for a in (corner, edge_u, edge_v))
    width, height, texel = texture_size(float(np.linalg.norm(edge_u)), float(np.linalg.norm(edge_v)), texel)
    vertices = np.stack([corner, corner + edge_u, corner + edge_u + edge_v, corner + edge_v])
    uvs = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    return Surface(vertices, np.array([[0, 1, 2], [0, 2, 3]]), uvs, painter(rng, height, width), texel)


def box(
    rng, centre, size, painter: Painter, texel: float, yaw: float = 0.0, top: Painter | None = None
) -> list[Surface]:
    """An axis-aligned (then yawed) box: six faces, each with its own texture drawn by ``painter``.

    ``top`` paints the upper face differently (a desk top, a keyboard on a case).
    """
    centre = np.asarray(centre, np.float64)
    half = np.asarray(size, np.float64) / 2
    R = Rotation.from_rotvec([0.0, 0.0, yaw]).as_matrix()
    ex, ey, ez = (R[:, i] * 2 * half[i] for i in range(3))
    low = centre - (ex + ey + ez) / 2
    # Each face from its top-left corner as seen from outside, so that text reads the right way.
    faces = [
        (low, ex, ey, painter),  # bottom
        (low + ez + ey, ex, -ey, top or painter),  # top
        (low + ez, ex, -ez, painter),  # front (-y)
        (low + ey + ex + ez, -ex, -ez, painter),  # back (+y)
        (low + ey + ez, -ey, -ez, painter),  # left (-x)
        (low + ex + ez, ey, -ez, painter),  # right (+x)
    ]
    return [quad(rng, c, u, v, p, texel) for c, u, v, p in faces]


def cylinder(
    rng, base_centre, radius: float, height: float, painter: Painter, texel: float, segments: int = 24
) -> list[Surface]:
    """A vertical cylinder: the side as one wrapped texture, and a cap on top."""
    base_centre = np.asarray(base_centre, np.float64)
    angles = np.linspace(0.0, 2 * np.pi, segments + 1)
    ring = np.stack([radius * np.cos(angles), radius * np.sin(angles), np.zeros_like(angles)], axis=1)
    vertices = np.concatenate([ring, ring + [0.0, 0.0, height]]) + base_centre
    s = np.arange(segments)
    n = segments + 1
    triangles = np.concatenate([np.stack([s, s + 1, s + n + 1], 1), np.stack([s, s + n + 1, s + n], 1)])
    u = angles / (2 * np.pi)
    uvs = np.concatenate([np.stack([u, np.ones_like(u)], 1), np.stack([u, np.zeros_like(u)], 1)])  # rows downwards
    width, tex_height, texel = texture_size(2 * np.pi * radius, height, texel)
    side = Surface(vertices, triangles, uvs, painter(rng, tex_height, width), texel)
    cap_vertices = np.concatenate([[base_centre + [0, 0, height]], vertices[n:]])
    cap_triangles = np.stack([np.zeros(segments, int), s + 1, s + 2], 1)
    cap_uvs = 0.5 + 0.5 * np.concatenate([[[0.0, 0.0]], np.stack([np.cos(angles), np.sin(angles)], 1)])
    size, _, cap_texel = texture_size(2 * radius, 2 * radius, texel)
    cap = Surface(cap_vertices, cap_triangles, cap_uvs, painter(rng, size, size), cap_texel)
    return [side, cap]


def room(
    rng, size, wall: Painter, floor: Painter, ceiling: Painter, texel: float, floor_texel: float | None = None
) -> list[Surface]:
    """Floor, ceiling and four walls of a box room with one corner at the origin."""
    w, d, h = size
    floor_texel = floor_texel or texel * 2
    return [
        quad(rng, (0, 0, 0), (w, 0, 0), (0, d, 0), floor, floor_texel),
        quad(rng, (0, 0, h), (w, 0, 0), (0, d, 0), ceiling, floor_texel * 2),
        quad(rng, (0, 0, h), (w, 0, 0), (0, 0, -h), wall, texel),
        quad(rng, (w, d, h), (-w, 0, 0), (0, 0, -h), wall, texel),
        quad(rng, (0, d, h), (0, -d, 0), (0, 0, -h), wall, texel),
        quad(rng, (w, 0, h), (0, d, 0), (0, 0, -h), wall, texel),
    ]


def wall_poster(
    rng,
    centre,
    normal_yaw: float,
    width: float,
    height: float,
    texel: float = 0.0015,
    painter: Painter = textures.poster,
) -> Surface:
    """A poster hanging 5 mm in front of a wall whose normal points along ``normal_yaw``."""
    normal = np.array([np.cos(normal_yaw), np.sin(normal_yaw), 0.0])
    across = np.array([-np.sin(normal_yaw), np.cos(normal_yaw), 0.0])  # left to right facing the wall
    corner = np.asarray(centre, np.float64) + 0.005 * normal - across * width / 2 + [0, 0, height / 2]
    return quad(rng, corner, across * width, [0.0, 0.0, -height], painter, texel)


def desk(rng, corner, size=(1.6, 0.8, 0.74)) -> list[Surface]:
    """A table: a wooden top slab and four legs."""
    x, y, z = corner
    w, d, h = size
    surfaces = box(rng, (x + w / 2, y + d / 2, z + h - 0.015), (w, d, 0.03), textures.wood, 0.002)
    metal = lambda r, hh, ww: textures.plain(r, hh, ww, (90, 90, 95), 6.0)  # noqa: E731
    for lx, ly in ((0.05, 0.05), (w - 0.05, 0.05), (0.05, d - 0.05), (w - 0.05, d - 0.05)):
        surfaces += box(rng, (x + lx, y + ly, z + (h - 0.03) / 2), (0.04, 0.04, h - 0.03), metal, 0.004)
    return surfaces


class PersonParts(TypedDict):
    """The separately movable parts of a person: static legs, a torso, and two arms."""

    legs: list[Surface]
    torso: list[Surface]
    arms: list[list[Surface]]


def person_parts(rng, shirt, trousers, skin=(205, 160, 130)) -> PersonParts:
    """A seated person in their own frame (origin on the floor below the seat, facing +x).

    Returned as named parts so that scenarios can move the torso and arms separately; each
    arm hangs from its shoulder at the part's origin.
    """
    cloth = lambda colour: lambda r, h, w: textures.fabric(r, h, w, colour)  # noqa: E731
    face = lambda r, h, w: textures.fabric(r, h, w, skin)  # noqa: E731
    return {
        "legs": box(rng, (0.15, 0.0, 0.45), (0.45, 0.36, 0.14), cloth(trousers), 0.004)
        + box(rng, (0.36, 0.0, 0.22), (0.12, 0.34, 0.44), cloth(trousers), 0.004),
        "torso": box(rng, (0.0, 0.0, 0.82), (0.24, 0.40, 0.60), cloth(shirt), 0.004)
        + cylinder(rng, (0.0, 0.0, 1.16), 0.10, 0.24, face, 0.003),
        "arms": [box(rng, (0.0, 0.0, -0.28), (0.09, 0.09, 0.56), cloth(shirt), 0.004) for _ in range(2)],
    }


def transformed(surfaces: Sequence[Surface], T: np.ndarray) -> list[Surface]:
    """Surfaces moved rigidly by the 4x4 transform ``T`` (textures shared)."""
    return [Surface(s.vertices @ T[:3, :3].T + T[:3, 3], s.triangles, s.uvs, s.texture, s.texel) for s in surfaces]


def yaw_pose(x: float, y: float, z: float, yaw: float, pitch: float = 0.0) -> np.ndarray:
    """Object pose from a position, a turn about the vertical and a tilt about the object's y axis."""
    return make_pose(
        Rotation.from_rotvec([0.0, 0.0, yaw]).as_matrix() @ Rotation.from_rotvec([0.0, pitch, 0.0]).as_matrix(),
        np.asarray([x, y, z], np.float64),
    )
