"""Ray-cast rendering of a :class:`Scene` into ideal colour and depth images.

:mod:`.raycast` intersects the rays (in float64, with the same bits on every CPU); each hit
gives the triangle and its barycentric coordinates. The time grows with the rays, so they are
cast adaptively: first on a grid of every fourth pixel, then on every second pixel of the
cells whose four corners do not all hit the same face (coplanar triangles with one texture
mapping, as a quad's two), then on every pixel of the 2-pixel cells that still do not.
Inside a cell on one face, inverse depth and texture coordinates over depth are linear in
the image, so bilinear interpolation gives them exactly, as perspective-correct
rasterisation does: a tenth to a sixth of the rays of one per pixel render the image.
What fits between the grid's rays is missed: an object narrower than four pixels in front
of one face, or a corner poking less than four pixels into a cell.

All textures live in one padded atlas with a three-level mip pyramid, so the colour lookup
is a handful of ``cv2.remap`` calls whatever the number of surfaces, and distant surfaces
are filtered instead of aliasing into flickering corners. Lights and static surfaces do
not move, so their Lambertian shading is baked once into a coarse light map over the atlas
(one for each side of a surface); only the movers are shaded per pixel.
"""

from dataclasses import dataclass

import cv2
import numpy as np

from ...geometry.camera import Camera
from .raycast import CasterFrame, TriangleCaster
from .scenes import Scene, Surface

ATLAS_WIDTH = 8192
ATLAS_PADDING = 16  # texels of replicated border: keeps level-2 filtering inside each texture
MIP_LEVELS = 3  # the atlas and two halvings
GRID_STEP = 4  # pixels between the rays of the first, coarse pass
LIGHT_STEP = 8  # atlas texels per light-map texel: lighting varies over centimetres, not texels


@dataclass
class Hits:
    """A colour render's per-pixel lookup, ``(H, W)`` arrays, and its coarse ray grid.

    ``triangle`` is one of the triangles of the face seen (they share normal, texture and
    plane), -1 where rays miss; ``grid_points`` ``(H', W', 3)`` are the world points
    hit by the coarse rays (every fourth pixel), ``grid_hit`` where they hit.
    """

    triangle: np.ndarray
    depth: np.ndarray  # z along the optical axis, 0 on a miss
    atlas_x: np.ndarray
    atlas_y: np.ndarray
    level: np.ndarray  # mip level from the pixel's footprint on the texture
    grid_points: np.ndarray
    grid_hit: np.ndarray


@dataclass
class _Rays:
    """Intersections of a flat batch of rays."""

    depth: np.ndarray  # z along the optical axis, 0 on a miss
    triangle: np.ndarray  # -1 on a miss
    barycentric: np.ndarray  # (N, 2)
    cos_incidence: np.ndarray
    directions: np.ndarray  # (N, 3) world frame, unit optical depth


def pack_atlas(images: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Shelf-pack padded textures into one image; returns it and each texture's top-left ``(x, y)``."""
    pad = ATLAS_PADDING
    order = sorted(range(len(images)), key=lambda i: (-images[i].shape[0], i))
    origins = np.zeros((len(images), 2), np.int64)
    x = y = shelf = 0
    for i in order:
        h, w = images[i].shape[0] + 2 * pad, images[i].shape[1] + 2 * pad
        if x + w > ATLAS_WIDTH:
            x, y, shelf = 0, y + shelf, 0
        origins[i] = (x, y)
        x, shelf = x + w, max(shelf, h)
    atlas = np.zeros((y + shelf, ATLAS_WIDTH, 3), np.uint8)
    for image, (ox, oy) in zip(images, origins):
        padded = cv2.copyMakeBorder(image, pad, pad, pad, pad, cv2.BORDER_REPLICATE)
        atlas[oy : oy + padded.shape[0], ox : ox + padded.shape[1]] = padded
    return atlas, origins


def mip_atlas(atlas: np.ndarray) -> tuple[np.ndarray, int, int]:
    """The atlas and its two smaller mip levels in one image: level 0 on top, levels 1 and 2
    side by side below it; also the row where level 1 starts and the column of level 2.

    One image, so that one ``cv2.remap`` reads each pixel from the level its footprint
    asks for; the textures' padding keeps the filtering inside each level.
    """
    level1 = cv2.pyrDown(atlas)
    level2 = cv2.pyrDown(level1)
    height, width = atlas.shape[0] + level1.shape[0], atlas.shape[1]
    if height >= np.iinfo(np.int16).max:  # cv2.remap addresses rows with 16 bits
        raise ValueError("textures exceed the atlas; use coarser texels")
    image = np.zeros((height, width, 4), np.uint8)  # RGBA: OpenCV's remap is vectorised for four channels
    image[: atlas.shape[0], :, :3] = atlas
    row, column = atlas.shape[0], level1.shape[1]
    image[row:, :column, :3] = level1
    image[row : row + level2.shape[0], column : column + level2.shape[1], :3] = level2
    return image, row, column


def rotate(vectors: np.ndarray, R: np.ndarray) -> np.ndarray:
    """``R @ v`` for every vector of an ``(..., 3)`` array.

    Written out as products and sums in a fixed order rather than ``@`` or einsum, whose
    BLAS kernels and SIMD loops round differently on different CPUs.
    """
    x, y, z = vectors[..., 0:1], vectors[..., 1:2], vectors[..., 2:3]
    return x * R[:, 0] + y * R[:, 1] + z * R[:, 2]


def dot3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dot products of ``(3, ...)`` coordinate planes, summed x, y, z in that order."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def lambert(points: np.ndarray, normals: np.ndarray, lights: np.ndarray, ambient: float) -> np.ndarray:
    """Light intensity at world points with unit normals, both ``(3, N)`` coordinate planes.

    Point lights with a soft fall-off (cosine over distance, halved at 5 m); 1 is the
    albedo's own brightness, which several lights facing a surface can exceed.
    """
    light = np.zeros(points.shape[1:], np.float32)
    for position in lights:
        to_light = position.astype(np.float32)[:, None] - points
        squared = dot3(to_light, to_light)
        light += np.maximum(dot3(normals, to_light), 0.0) / (np.sqrt(squared) * (1.0 + squared / 25.0) + 1e-6)
    return ambient + (1 - ambient) * 1.6 / len(lights) * light


def pixel_rays(camera: Camera, cols: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Camera-frame ray directions with unit z through pixel columns x rows, ``(R, C, 3)`` float32.

    With z = 1 the ray parameter of a hit is the depth itself.
    """
    u, v = np.meshgrid(np.asarray(cols, np.float64), np.asarray(rows, np.float64))
    return np.stack([(u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, np.ones_like(u)], axis=-1).astype(
        np.float32
    )


@dataclass(frozen=True)
class _Samples:
    """Pixels sampled every ``step`` pixels from the top-left one, in a grid ``shape``: their
    column and row ``(N, 2)``, and the lengths of their camera-frame rays of unit z."""

    shape: tuple[int, int]
    pixels: np.ndarray
    norms: np.ndarray

    @staticmethod
    def grid(camera: Camera, shape: tuple[int, int], step: int) -> tuple[np.ndarray, np.ndarray]:
        rows, cols = np.indices(shape)
        pixels = np.stack([cols.ravel() * step, rows.ravel() * step], axis=-1).astype(np.float64)
        x, y = (pixels[:, 0] - camera.cx) / camera.fx, (pixels[:, 1] - camera.cy) / camera.fy
        return pixels, np.sqrt(x * x + y * y + 1.0)

    @classmethod
    def every(cls, camera: Camera, shape: tuple[int, int], step: int) -> "_Samples":
        return cls(shape, *cls.grid(camera, shape, step))


@dataclass(frozen=True)
class _Level(_Samples):
    """The samples of one refinement, each between the samples of a twice coarser level.

    ``cell`` and ``corner`` give each sample's coarse cell and that cell's top-left coarse
    sample (clamped: the last row or column belongs to the cell before it); ``maps`` its
    coarse coordinates for ``cv2.remap`` (halves: exact in OpenCV's fixed-point weights).
    """

    cell: np.ndarray
    corner: np.ndarray
    maps: tuple[np.ndarray, np.ndarray]

    @classmethod
    def between(cls, camera: Camera, coarse: tuple[int, int], shape: tuple[int, int], step: int) -> "_Level":
        """Samples ``shape`` every ``step`` pixels from the top-left one, in a coarse grid ``coarse``."""
        rows, cols = np.indices(shape)
        cell_row, cell_col = np.minimum(rows // 2, coarse[0] - 2), np.minimum(cols // 2, coarse[1] - 2)
        return cls(
            shape,
            *cls.grid(camera, shape, step),
            (cell_row * (coarse[1] - 1) + cell_col).ravel(),
            (cell_row * coarse[1] + cell_col).ravel(),
            ((cols / 2).astype(np.float32), (rows / 2).astype(np.float32)),
        )


def _mixed_cells(face: np.ndarray) -> np.ndarray:
    """Cells ``(H - 1, W - 1)`` of a sample grid whose four corners do not all see one face."""
    top_left = face[:-1, :-1]
    return (top_left != face[1:, :-1]) | (top_left != face[:-1, 1:]) | (top_left != face[1:, 1:])


def _barycentric_in(uv: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Barycentric coordinates ``(T, G, 3)`` of 2D points ``(G, 2)`` in triangles ``(T, 3, 2)``."""
    a, b, c = corners[:, 0, None], corners[:, 1, None], corners[:, 2, None]
    e1, e2, p = b - a, c - a, uv[None] - a
    det = e1[..., 0] * e2[..., 1] - e1[..., 1] * e2[..., 0]
    det = np.where(np.abs(det) > 1e-12, det, 1e-12)
    b1 = (p[..., 0] * e2[..., 1] - p[..., 1] * e2[..., 0]) / det
    b2 = (e1[..., 0] * p[..., 1] - e1[..., 1] * p[..., 0]) / det
    return np.stack([1 - b1 - b2, b1, b2], axis=-1)


def face_normals(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Unit normals ``(T, 3)`` of triangles (the side is the winding's; shading picks the seen one)."""
    v = vertices[triangles]
    n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)


def bake_light_maps(
    surfaces: list[Surface], origins: np.ndarray, atlas_shape: tuple[int, int], lights: np.ndarray, ambient: float
) -> np.ndarray:
    """Light intensity over the atlas, ``(2 H / 8 + 2, W / 8)`` float32: each surface's
    front (its winding's normal) above its back side, two blank rows between them so that
    filtering never mixes the sides.

    Each light-map texel centre takes the world point of its texture coordinates on the
    triangle containing them (extrapolated from the nearest one in the padding).
    """
    height, width = -(-atlas_shape[0] // LIGHT_STEP), atlas_shape[1] // LIGHT_STEP
    maps = np.zeros((2, height + 2, width), np.float32)
    for surface, (ox, oy) in zip(surfaces, origins):
        h, w = surface.texture.shape[:2]
        # The light texels whose centres, at atlas coordinate (k + 0.5) * step - 0.5, fall in the padded texture.
        cols = np.arange(
            int(np.ceil((ox + 0.5) / LIGHT_STEP - 0.5)),
            int(np.floor((ox + w + 2 * ATLAS_PADDING - 0.5) / LIGHT_STEP - 0.5)) + 1,
        )
        rows = np.arange(
            int(np.ceil((oy + 0.5) / LIGHT_STEP - 0.5)),
            int(np.floor((oy + h + 2 * ATLAS_PADDING - 0.5) / LIGHT_STEP - 0.5)) + 1,
        )
        if not len(cols) or not len(rows):
            continue
        u = ((cols + 0.5) * LIGHT_STEP - ox - ATLAS_PADDING) / w
        v = ((rows + 0.5) * LIGHT_STEP - oy - ATLAS_PADDING) / h
        u, v = np.meshgrid(u, v)
        bary = _barycentric_in(np.stack([u.ravel(), v.ravel()], -1), surface.uvs[surface.triangles])
        best = np.argmax(bary.min(axis=-1), axis=0)  # the containing triangle, or the nearest
        weights = bary[best, np.arange(len(best))]
        corners = surface.vertices[surface.triangles[best]]
        points = weights[:, 0:1] * corners[:, 0] + weights[:, 1:2] * corners[:, 1] + weights[:, 2:3] * corners[:, 2]
        normals = face_normals(surface.vertices, surface.triangles)[best]
        for side, sign in enumerate((1.0, -1.0)):
            intensity = lambert(points.T.astype(np.float32), (sign * normals).T.astype(np.float32), lights, ambient)
            maps[side, rows[0] : rows[-1] + 1, cols[0] : cols[-1] + 1] = intensity.reshape(u.shape)
    return maps.reshape(-1, width)[:-2]


def faces(surface: Surface) -> np.ndarray:
    """Face index of each triangle of a surface: triangles share a face when one affine map
    takes texture coordinates to world points on all of them (so they are coplanar and one
    texture mapping) and their union is convex, as a quad's two triangles or a cap's fan are.

    Across a face, inverse depth and texture coordinates over depth are linear in the image.
    """
    uv = surface.uvs[surface.triangles]
    xyz = surface.vertices[surface.triangles]
    uv_edges = np.stack([uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]], axis=-1)  # (T, 2, 2) columns
    degenerate = np.abs(np.linalg.det(uv_edges)) < 1e-12
    uv_edges[degenerate] = np.eye(2)
    linear = np.stack([xyz[:, 1] - xyz[:, 0], xyz[:, 2] - xyz[:, 0]], axis=-1) @ np.linalg.inv(uv_edges)  # (T, 3, 2)
    maps = np.concatenate([linear, (xyz[:, 0] - np.einsum("tij,tj->ti", linear, uv[:, 0]))[..., None]], axis=-1)
    scale = max(float(np.abs(maps).max()), 1e-9)
    keys = np.round(maps.reshape(len(maps), -1) / scale, 6)
    keys[degenerate] = np.nan
    face = np.arange(len(maps))
    group = np.unique(keys, axis=0, return_inverse=True)[1].ravel()
    for g in range(group.max() + 1):
        members = np.flatnonzero(group == g)
        if len(members) < 2 or degenerate[members[0]]:
            continue
        corners = uv[members].reshape(-1, 2).astype(np.float32)
        area = np.abs(np.linalg.det(uv_edges[members])).sum() / 2
        if abs(cv2.contourArea(cv2.convexHull(corners)) - area) <= 1e-6 * area:
            face[members] = members[0]
    return face


class Renderer:
    """Renders a scene through a camera at a pose and a time (the time places the movers)."""

    def __init__(self, scene: Scene, camera: Camera):
        self.scene = scene
        self.camera = camera
        surfaces: list[Surface] = scene.static + [s for m in scene.movers for s in m.surfaces]
        atlas, origins = pack_atlas([s.texture for s in surfaces])
        self.mips, self._level1_row, self._level2_column = mip_atlas(atlas)
        triangles, corner_uv, texel, face, offset, first = [], [], [], [], 0, 0
        for surface, (ox, oy) in zip(surfaces, origins):
            h, w = surface.texture.shape[:2]
            uv = surface.uvs[surface.triangles]  # (T, 3, 2)
            corner_uv.append(
                np.stack(
                    [ox + ATLAS_PADDING + uv[..., 0] * w - 0.5, oy + ATLAS_PADDING + uv[..., 1] * h - 0.5], axis=-1
                )
            )
            triangles.append(surface.triangles + offset)
            texel.append(np.full(len(surface.triangles), surface.texel))
            face.append(faces(surface) + first)  # faces are named by a triangle's global index
            offset, first = offset + len(surface.vertices), first + len(surface.triangles)
        self.triangles = np.concatenate(triangles).astype(np.uint32)
        # Atlas x and y of each triangle's corners, (T, 6): x0, y0, x1, y1, x2, y2.
        self.corner_uv = np.concatenate(corner_uv).astype(np.float32).reshape(-1, 6)
        self.texel = np.concatenate(texel).astype(np.float32)
        self.face = np.append(np.concatenate(face), -1).astype(np.int32)  # indexed by triangle, -1 for a miss
        self.static_vertices = np.concatenate([s.vertices for s in scene.static]) if scene.static else np.zeros((0, 3))
        self.static_triangles = sum(len(s.triangles) for s in scene.static)
        self._caster = TriangleCaster(self.triangles, camera)
        # Without movers the geometry is the same at every time: computed once.
        self._static_geometry = None if scene.movers else self._geometry(self.static_vertices)
        self._lights = np.asarray(scene.lights, np.float64)
        self.light_maps = bake_light_maps(
            scene.static, origins[: len(scene.static)], atlas.shape[:2], self._lights, scene.ambient
        )
        # The grid reaches the last row and column, so that interpolation covers every pixel.
        self._grid_shape = (-(-(camera.height - 1) // GRID_STEP) + 1, -(-(camera.width - 1) // GRID_STEP) + 1)
        self._grid = _Samples.every(camera, self._grid_shape, GRID_STEP)
        half = (2 * self._grid_shape[0] - 1, 2 * self._grid_shape[1] - 1)
        self._levels = (
            _Level.between(camera, self._grid_shape, half, GRID_STEP // 2),
            _Level.between(camera, half, (camera.height, camera.width), 1),
        )
        self._pixel_rays = pixel_rays(camera, np.arange(camera.width), np.arange(camera.height)).reshape(-1, 3)

    def _geometry(self, vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return vertices, face_normals(vertices, self.triangles)

    def _geometry_at(self, time: float) -> tuple[np.ndarray, np.ndarray]:
        """Every vertex at ``time`` (the movers placed) and every triangle's unit normal."""
        if self._static_geometry is not None:
            return self._static_geometry
        parts = [self.static_vertices]
        for mover in self.scene.movers:
            T = mover.pose(time)
            parts += [rotate(s.vertices, T[:3, :3]) + T[:3, 3] for s in mover.surfaces]
        return self._geometry(np.concatenate(parts))

    def _frame_at(self, time: float, pose: np.ndarray) -> tuple[CasterFrame, np.ndarray]:
        """The triangles at ``time`` seen from ``pose``, and their unit normals."""
        vertices, normals = self._geometry_at(time)
        return self._caster.frame(vertices, pose), normals

    @staticmethod
    def _cast(scene: tuple[CasterFrame, np.ndarray], samples: "_Samples", which: np.ndarray | None = None) -> _Rays:
        """Intersect the rays of ``samples`` (those at indices ``which``, else all) with the
        frame's triangles."""
        frame, normals = scene
        pixels, norms = (
            (samples.pixels, samples.norms) if which is None else (samples.pixels[which], samples.norms[which])
        )
        hits = frame.cast(pixels)
        hit = hits.triangle >= 0
        cos = np.abs(dot3(normals[np.maximum(hits.triangle, 0)].T, hits.directions.T)) / norms
        return _Rays(
            np.where(hit, hits.t, 0.0).astype(np.float32),
            hits.triangle,
            hits.barycentric.astype(np.float32),
            cos.astype(np.float32),
            hits.directions.astype(np.float32),
        )

    def _adaptive(self, scene, values) -> tuple[np.ndarray, np.ndarray, _Rays]:
        """Per-pixel ``values`` (a function of a :class:`_Rays`, ``(N, 4)``, linear in the
        image across a face), the pixels' triangles, and the coarse grid's rays.

        From the grid of every fourth pixel to every second one, then to every pixel: each
        time rays are cast only in the cells whose corners see more than one face.
        """
        grid = self._cast(scene, self._grid)
        samples, triangle = values(grid), grid.triangle
        shape = self._grid_shape
        for level in self._levels:
            mixed = _mixed_cells(self.face[triangle].reshape(shape))
            # Four channels: OpenCV's remap is vectorised for one or four, two or three take twice as long.
            samples = cv2.remap(
                samples.reshape(shape + (4,)), *level.maps, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE
            ).reshape(-1, 4)
            triangle = triangle[level.corner]
            exact = np.flatnonzero(mixed.ravel()[level.cell])
            if len(exact):
                fine = self._cast(scene, level, exact)
                samples[exact] = values(fine)
                triangle[exact] = fine.triangle
            shape = level.shape
        return samples, triangle.reshape(shape), grid

    def _lookup(self, rays: _Rays) -> np.ndarray:
        """Atlas x and y over depth, inverse depth and mip level of each ray, ``(N, 4)`` (zero
        on a miss): the first three are linear in the image across a face."""
        hit = rays.triangle >= 0
        triangle = np.maximum(rays.triangle, 0)
        corners = self.corner_uv[triangle]
        b1, b2 = rays.barycentric.T
        b0 = 1 - b1 - b2
        out = np.empty((len(triangle), 4), np.float32)
        inverse = np.divide(1.0, rays.depth, out=np.zeros_like(rays.depth), where=hit)
        out[:, 0] = (corners[:, 0] * b0 + corners[:, 2] * b1 + corners[:, 4] * b2) * inverse
        out[:, 1] = (corners[:, 1] * b0 + corners[:, 3] * b1 + corners[:, 5] * b2) * inverse
        out[:, 2] = inverse
        footprint = rays.depth / (
            np.float32(self.camera.fx)
            * self.texel[triangle]
            * np.sqrt(np.maximum(rays.cos_incidence, np.float32(0.05)))
        )
        out[:, 3] = np.clip(np.log2(np.maximum(footprint, np.float32(1e-6))), 0, MIP_LEVELS - 1) * hit
        return out

    def cast(self, pose: np.ndarray, time: float) -> Hits:
        """The texture lookup of every pixel from the camera at ``pose`` (T_world_camera)."""
        dense, triangle, grid = self._adaptive(self._frame_at(time, pose), self._lookup)
        shape = triangle.shape
        depth = np.divide(1.0, dense[:, 2], out=np.zeros(len(dense), np.float32), where=dense[:, 2] > 0)
        grid_shape = self._grid_shape
        grid_points = pose[:3, 3].astype(np.float32) + grid.directions * grid.depth[:, None]
        return Hits(
            triangle,
            depth.reshape(shape),
            (dense[:, 0] * depth).reshape(shape),
            (dense[:, 1] * depth).reshape(shape),
            dense[:, 3].reshape(shape),
            grid_points.reshape(grid_shape + (3,)),
            grid.triangle.reshape(grid_shape) >= 0,
        )

    def albedo(self, hits: Hits) -> np.ndarray:
        """Trilinearly filtered texture colour per pixel, uint8 ``(H, W, 3)``: bilinear in
        the two mip levels around the pixel's level (0 and 1, or 1 and 2), blended by its
        fraction."""
        upper = (hits.level >= 1.0).astype(np.float32)  # 1 where the levels are 1 and 2
        fraction = hits.level - upper
        level1_y, level2_x = np.float32(self._level1_row), np.float32(self._level2_column)
        half = np.float32(0.5)
        x = (hits.atlas_x + half) * (1.0 - half * upper)  # in the lower level's texels
        y = (hits.atlas_y + half) * (1.0 - half * upper)
        lower = cv2.remap(self.mips, x - half, y - half + level1_y * upper, cv2.INTER_LINEAR)
        x *= half
        y *= half
        higher = cv2.remap(self.mips, x - half + level2_x * upper, y - half + level1_y, cv2.INTER_LINEAR)
        return cv2.cvtColor(cv2.blendLinear(lower, higher, 1.0 - fraction, fraction), cv2.COLOR_RGBA2RGB)

    def light(self, hits: Hits, pose: np.ndarray, time: float) -> np.ndarray:
        """Light intensity per pixel: from the light map on static surfaces, on the side the
        camera sees; computed per pixel on movers."""
        vertices, normals = self._geometry_at(time)
        back = dot3(normals.T, (pose[:3, 3] - vertices[self.triangles[:, 0]]).T) < 0  # seen from behind
        back_rows = np.append(back * np.float32((self.light_maps.shape[0] + 2) // 2), np.float32(0.0))
        scale = np.float32(1.0 / LIGHT_STEP)
        map_x = (hits.atlas_x + 0.5) * scale - 0.5
        map_y = (hits.atlas_y + 0.5) * scale - 0.5 + back_rows[hits.triangle]  # a miss (-1) takes the last
        intensity = cv2.remap(self.light_maps, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        moving = np.flatnonzero(hits.triangle.ravel() >= self.static_triangles)
        if len(moving):
            triangle = hits.triangle.ravel()[moving]
            facing = np.where(back[triangle, None], -normals[triangle], normals[triangle])
            points = pose[:3, 3] + rotate(self._pixel_rays[moving], pose[:3, :3]) * hits.depth.ravel()[moving, None]
            intensity.ravel()[moving] = lambert(
                points.T.astype(np.float32), facing.T.astype(np.float32), self._lights, self.scene.ambient
            )
        return intensity

    def shade(self, hits: Hits, pose: np.ndarray, time: float) -> np.ndarray:
        """Lambertian shading of the texture colour, uint8 RGB: saturated where lights add up
        beyond white, as a sensor saturates."""
        intensity = self.light(hits, pose, time)
        colour = cv2.multiply(self.albedo(hits), cv2.merge([intensity] * 3), dtype=cv2.CV_8U)
        colour[hits.triangle < 0] = self.scene.background
        return colour

    def colour(self, pose: np.ndarray, time: float) -> tuple[np.ndarray, Hits]:
        """The ideal colour image at ``pose`` and ``time``, with its hits."""
        hits = self.cast(pose, time)
        return self.shade(hits, pose, time), hits

    def depth(self, pose: np.ndarray, time: float) -> tuple[np.ndarray, np.ndarray]:
        """Ideal depth (metres, 0 on a miss) and incidence cosine of every pixel.

        Exact on every pixel: inverse depth is linear across a face, and cells that see
        more than one are ray cast per pixel. The cosine, not linear, is interpolated
        bilinearly inside a face's cells (it varies slowly across a plane).
        """

        def inverse_and_cos(rays: _Rays) -> np.ndarray:  # two spare channels: see _adaptive
            out = np.zeros((len(rays.depth), 4), np.float32)
            np.divide(1.0, rays.depth, out=out[:, 0], where=rays.depth > 0)
            out[:, 1] = rays.cos_incidence
            return out

        dense, triangle, _ = self._adaptive(self._frame_at(time, pose), inverse_and_cos)
        depth = np.divide(1.0, dense[:, 0], out=np.zeros(len(dense), np.float32), where=dense[:, 0] > 0)
        return depth.reshape(triangle.shape), np.ascontiguousarray(dense[:, 1].reshape(triangle.shape))
