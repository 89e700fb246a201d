"""Rays against triangles, with the same bits on every x86-64 CPU.

A rendered frame must not depend on the processor that rendered it: the pipelines see its
last bits (a texel lookup rounds to another fixed-point step, a depth to another 0.2 mm
quantum, a corner response crosses its threshold), and one frame rendered differently sends
a run down another path. Embree (Open3D's ``RaycastingScene``) does not give that: it
intersects in float32 through approximate reciprocals (``vrcpps``), whose results the x86
architecture leaves to each implementation, so an Intel and an AMD processor running the
same AVX2 kernel return hits a few units in the last place apart.

Here every ray is intersected in float64 by the Möller–Trumbore test, written with
additions, multiplications and divisions only, each rounded exactly as IEEE 754 requires;
numba compiles it without fast-math, so no product is fused into an addition and no sum is
reordered. The nearest hit wins, the lower triangle index on an exact tie. To test only the
triangles a ray can meet, each frame's triangles are first sorted into square tiles of the
image by their projected bounding boxes (clipped to the near plane, padded by a pixel): a
conservative choice, so the tiles change which triangles are tested, never the hit.
"""

from dataclasses import dataclass

import numpy as np

from ...compiled import jit
from ...geometry.camera import Camera

TILE = 16  # pixels on a side of a tile of the image
NEAR = 1e-3  # metres: hits nearer the camera's centre than this are ignored


@dataclass(frozen=True)
class Tiles:
    """A frame's triangles sorted into tiles: tile ``k``'s are ``items[start[k]:start[k + 1]]``,
    in ascending order."""

    start: np.ndarray
    items: np.ndarray
    columns: int


@dataclass(frozen=True)
class RayHits:
    """Intersections of a batch of rays, float64."""

    t: np.ndarray  # ray parameter = depth along the optical axis (unit-z rays); inf on a miss
    triangle: np.ndarray  # int32, -1 on a miss
    barycentric: np.ndarray  # (N, 2): the weights of each hit triangle's second and third vertices
    directions: np.ndarray  # (N, 3) world frame, unit optical depth


@jit
def _clipped_bounds(a, b, c, near):
    """Pixel-plane bounding box (x0, y0, x1, y1) of a camera-frame triangle's part at depth
    ``near`` or more, in normalised image coordinates; x0 > x1 when nothing is left."""
    x0, y0, x1, y1 = np.inf, np.inf, -np.inf, -np.inf
    corners = (a, b, c)
    for k in range(3):
        p, q = corners[k], corners[(k + 1) % 3]
        if p[2] >= near:
            x, y = p[0] / p[2], p[1] / p[2]
            x0, y0, x1, y1 = min(x0, x), min(y0, y), max(x1, x), max(y1, y)
        if (p[2] >= near) != (q[2] >= near):  # the edge crosses the near plane: add the crossing
            s = (near - p[2]) / (q[2] - p[2])
            x, y = (p[0] + s * (q[0] - p[0])) / near, (p[1] + s * (q[1] - p[1])) / near
            x0, y0, x1, y1 = min(x0, x), min(y0, y), max(x1, x), max(y1, y)
    return x0, y0, x1, y1


@jit
def _tile_ranges(vertices, triangles, rotation, centre, fx, fy, cx, cy, columns, rows, tile, near):
    """Each triangle's range of tiles (first column, first row, last column, last row); an
    empty range (first > last) for a triangle out of view."""
    count = triangles.shape[0]
    ranges = np.empty((count, 4), np.int64)
    local = np.empty((3, 3))
    width, height = columns * tile, rows * tile
    last_column, last_row = columns - 1, rows - 1
    for i in range(count):
        for k in range(3):
            d = vertices[triangles[i, k]] - centre
            for axis in range(3):  # R^T d: the vertex in the camera frame
                local[k, axis] = rotation[0, axis] * d[0] + rotation[1, axis] * d[1] + rotation[2, axis] * d[2]
        x0, y0, x1, y1 = _clipped_bounds(local[0], local[1], local[2], near)
        if x0 > x1:
            ranges[i] = (1, 1, 0, 0)
            continue
        # In pixels, padded by one, clamped to the tiles (a ray's pixel lies inside its hit's box).
        u0, u1 = max(fx * x0 + cx - 1.0, 0.0), min(fx * x1 + cx + 1.0, width - 1.0)
        v0, v1 = max(fy * y0 + cy - 1.0, 0.0), min(fy * y1 + cy + 1.0, height - 1.0)
        if u0 > u1 or v0 > v1:
            ranges[i] = (1, 1, 0, 0)
            continue
        ranges[i] = (
            min(int(u0) // tile, last_column),
            min(int(v0) // tile, last_row),
            min(int(u1) // tile, last_column),
            min(int(v1) // tile, last_row),
        )
    return ranges


@jit
def _tiles(ranges, columns, rows):
    """Compressed rows of the tiles' triangle lists, each in ascending order."""
    start = np.zeros(columns * rows + 1, np.int64)
    for i in range(ranges.shape[0]):
        c0, r0, c1, r1 = ranges[i]
        for r in range(r0, r1 + 1):
            for c in range(c0, c1 + 1):
                start[r * columns + c + 1] += 1
    for k in range(columns * rows):
        start[k + 1] += start[k]
    items = np.empty(start[-1], np.int64)
    fill = start[:-1].copy()
    for i in range(ranges.shape[0]):
        c0, r0, c1, r1 = ranges[i]
        for r in range(r0, r1 + 1):
            for c in range(c0, c1 + 1):
                items[fill[r * columns + c]] = i
                fill[r * columns + c] += 1
    return start, items


@jit
def _cast(cols, rows, rotation, centre, fx, fy, cx, cy, origin, edge1, edge2, start, items, columns, tile, near):
    """Nearest hit of the ray through each pixel (``cols``, ``rows``), by Möller–Trumbore."""
    count = cols.shape[0]
    t_hit = np.full(count, np.inf)
    triangle = np.full(count, -1, np.int32)
    barycentric = np.zeros((count, 2))
    directions = np.empty((count, 3))
    for n in range(count):
        x, y = (cols[n] - cx) / fx, (rows[n] - cy) / fy
        d0 = rotation[0, 0] * x + rotation[0, 1] * y + rotation[0, 2]
        d1 = rotation[1, 0] * x + rotation[1, 1] * y + rotation[1, 2]
        d2 = rotation[2, 0] * x + rotation[2, 1] * y + rotation[2, 2]
        directions[n, 0], directions[n, 1], directions[n, 2] = d0, d1, d2
        k = (int(rows[n]) // tile) * columns + int(cols[n]) // tile
        best, best_u, best_v, best_i = np.inf, 0.0, 0.0, -1
        for m in range(start[k], start[k + 1]):
            i = items[m]
            a0, a1, a2 = edge1[i, 0], edge1[i, 1], edge1[i, 2]
            b0, b1, b2 = edge2[i, 0], edge2[i, 1], edge2[i, 2]
            p0, p1, p2 = d1 * b2 - d2 * b1, d2 * b0 - d0 * b2, d0 * b1 - d1 * b0
            det = a0 * p0 + a1 * p1 + a2 * p2
            if det == 0.0:
                continue  # the ray runs in the triangle's plane
            s0, s1, s2 = centre[0] - origin[i, 0], centre[1] - origin[i, 1], centre[2] - origin[i, 2]
            u = (s0 * p0 + s1 * p1 + s2 * p2) / det
            if u < 0.0 or u > 1.0:
                continue
            q0, q1, q2 = s1 * a2 - s2 * a1, s2 * a0 - s0 * a2, s0 * a1 - s1 * a0
            v = (d0 * q0 + d1 * q1 + d2 * q2) / det
            if v < 0.0 or u + v > 1.0:
                continue
            t = (b0 * q0 + b1 * q1 + b2 * q2) / det
            if near < t < best:
                best, best_u, best_v, best_i = t, u, v, i
        t_hit[n], triangle[n] = best, best_i
        barycentric[n, 0], barycentric[n, 1] = best_u, best_v
    return t_hit, triangle, barycentric, directions


class TriangleCaster:
    """Casts pixel rays of ``camera`` against triangles (indices into vertices given per
    frame, so that moving surfaces move).

    Pixels may lie up to a tile beyond the image's last column and row (a coarse grid that
    reaches the image's edge from outside).
    """

    def __init__(self, triangles: np.ndarray, camera: Camera):
        self.triangles = np.ascontiguousarray(triangles, np.int64)
        self.camera = camera
        self._columns = camera.width // TILE + 2
        self._rows = camera.height // TILE + 2

    def frame(self, vertices: np.ndarray, pose: np.ndarray) -> "CasterFrame":
        """The triangles at ``vertices`` (world frame) seen from ``pose`` (T_world_camera)."""
        vertices = np.ascontiguousarray(vertices, np.float64)
        rotation, centre = np.ascontiguousarray(pose[:3, :3], np.float64), np.ascontiguousarray(pose[:3, 3], np.float64)
        cam = self.camera
        ranges = _tile_ranges(
            vertices,
            self.triangles,
            rotation,
            centre,
            cam.fx,
            cam.fy,
            cam.cx,
            cam.cy,
            self._columns,
            self._rows,
            TILE,
            NEAR,
        )
        start, items = _tiles(ranges, self._columns, self._rows)
        corners = vertices[self.triangles]
        return CasterFrame(
            self,
            rotation,
            centre,
            np.ascontiguousarray(corners[:, 0]),
            np.ascontiguousarray(corners[:, 1] - corners[:, 0]),
            np.ascontiguousarray(corners[:, 2] - corners[:, 0]),
            Tiles(start, items, self._columns),
        )


@dataclass(frozen=True)
class CasterFrame:
    """One frame's triangles and tiles, ready to cast any set of its pixels' rays."""

    caster: TriangleCaster
    rotation: np.ndarray
    centre: np.ndarray
    origin: np.ndarray
    edge1: np.ndarray
    edge2: np.ndarray
    tiles: Tiles

    def cast(self, pixels: np.ndarray) -> RayHits:
        """The rays through ``pixels`` ``(N, 2)`` (column, row; integers, from 0 to a tile
        beyond the image)."""
        cam = self.caster.camera
        t, triangle, barycentric, directions = _cast(
            np.ascontiguousarray(pixels[:, 0], np.float64),
            np.ascontiguousarray(pixels[:, 1], np.float64),
            self.rotation,
            self.centre,
            cam.fx,
            cam.fy,
            cam.cx,
            cam.cy,
            self.origin,
            self.edge1,
            self.edge2,
            self.tiles.start,
            self.tiles.items,
            self.tiles.columns,
            TILE,
            NEAR,
        )
        return RayHits(t, triangle, barycentric, directions)
