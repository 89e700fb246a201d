"""Ray-cast rendering of a :class:`Scene` into ideal colour and depth images.

Open3D's ``RaycastingScene`` (Embree) intersects one ray per pixel, all at once; each hit
gives the triangle, its barycentric coordinates and face normal. All textures live in one
padded atlas with a three-level mip pyramid, so the colour lookup is a handful of
``cv2.remap`` calls whatever the number of surfaces, and distant surfaces are filtered
instead of aliasing into flickering corners.
"""

from dataclasses import dataclass

import cv2
import numpy as np

from ...geometry.camera import Camera
from ...open3d_loader import import_open3d
from .scenes import Scene, Surface

ATLAS_WIDTH = 8192
ATLAS_PADDING = 16   # texels of replicated border: keeps level-2 filtering inside each texture
MIP_LEVELS = 3
DEPTH_STEP = 2       # depth is ray cast on every second pixel and upsampled (planes stay exact)


@dataclass
class Hits:
    """Per-pixel intersection results, ``(H, W)`` arrays; ``triangle`` is -1 where rays miss."""

    depth: np.ndarray       # z along the optical axis, 0 on a miss
    triangle: np.ndarray
    barycentric: np.ndarray  # (H, W, 2)
    normal: np.ndarray       # (H, W, 3) world frame, facing the camera
    cos_incidence: np.ndarray
    points: np.ndarray       # (H, W, 3) world frame


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
    if atlas.shape[0] >= np.iinfo(np.int16).max:
        raise ValueError("textures exceed the atlas; use coarser texels")
    for image, (ox, oy) in zip(images, origins):
        padded = cv2.copyMakeBorder(image, pad, pad, pad, pad, cv2.BORDER_REPLICATE)
        atlas[oy:oy + padded.shape[0], ox:ox + padded.shape[1]] = padded
    return atlas, origins


def rotate(vectors: np.ndarray, R: np.ndarray) -> np.ndarray:
    """``R @ v`` for every vector of an ``(..., 3)`` array.

    einsum rather than ``@``: a threaded BLAS spends more time spinning than computing on
    such tall, thin products.
    """
    return np.einsum("...j,ij->...i", vectors, R)


def dot3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per-pixel dot products of ``(3, H, W)`` coordinate planes, summed x, y, z in that order."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def pixel_rays(camera: Camera, step: int = 1) -> np.ndarray:
    """Camera-frame ray directions with unit z for every ``step``-th pixel, ``(H', W', 3)``.

    With z = 1 the ray parameter of a hit is the depth itself. With ``step`` > 1 the grid
    reaches the last row and column, so that upsampling interpolates everywhere.
    """
    cols = np.arange(0, camera.width + step - 1, step, dtype=np.float64)  # the last sample at or past the border
    rows = np.arange(0, camera.height + step - 1, step, dtype=np.float64)
    u, v = np.meshgrid(cols, rows)
    return np.stack([(u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, np.ones_like(u)], axis=-1)


class Renderer:
    """Renders a scene through a camera at a pose and a time (the time places the movers).

    ``threads`` bounds Embree's threads (0: all cores); a hit does not depend on it.
    """

    def __init__(self, scene: Scene, camera: Camera, threads: int = 0):
        self.o3d = import_open3d()
        self.threads = threads
        self.scene = scene
        self.camera = camera
        surfaces: list[Surface] = scene.static + [s for m in scene.movers for s in m.surfaces]
        atlas, origins = pack_atlas([s.texture for s in surfaces])
        self.levels = [atlas]
        for _ in range(MIP_LEVELS - 1):
            self.levels.append(cv2.pyrDown(self.levels[-1]))
        triangles, corner_uv, texel, offset = [], [], [], 0
        for surface, (ox, oy) in zip(surfaces, origins):
            h, w = surface.texture.shape[:2]
            uv = surface.uvs[surface.triangles]  # (T, 3, 2)
            corner_uv.append(np.stack([ox + ATLAS_PADDING + uv[..., 0] * w - 0.5,
                                       oy + ATLAS_PADDING + uv[..., 1] * h - 0.5], axis=-1))
            triangles.append(surface.triangles + offset)
            texel.append(np.full(len(surface.triangles), surface.texel))
            offset += len(surface.vertices)
        self.triangles = np.concatenate(triangles).astype(np.uint32)
        # Atlas x and y of each triangle's corners as (corner, axis, triangle) planes.
        self.corner_uv = np.ascontiguousarray(np.concatenate(corner_uv).astype(np.float32).transpose(1, 2, 0))
        self.texel = np.concatenate(texel).astype(np.float32)
        self.static_vertices = np.concatenate([s.vertices for s in scene.static]) if scene.static else np.zeros((0, 3))
        self._static_scene = None if scene.movers else self._raycasting_scene(self.static_vertices)
        self._rays = {step: pixel_rays(camera, step) for step in (1, DEPTH_STEP)}
        self._ray_norms = {step: np.linalg.norm(rays, axis=-1).astype(np.float32) for step, rays in self._rays.items()}
        self._lights = np.asarray(scene.lights, np.float64)
        rows, cols = np.indices((camera.height, camera.width))
        self._half_index = (rows // DEPTH_STEP, cols // DEPTH_STEP)
        self._half_maps = ((cols / DEPTH_STEP).astype(np.float32), (rows / DEPTH_STEP).astype(np.float32))

    def _raycasting_scene(self, vertices: np.ndarray):
        o3d = self.o3d
        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(o3d.core.Tensor(np.ascontiguousarray(vertices, np.float32)),
                            o3d.core.Tensor(self.triangles))
        return scene

    def _scene_at(self, time: float):
        if self._static_scene is not None:
            return self._static_scene
        parts = [self.static_vertices]
        for mover in self.scene.movers:
            T = mover.pose(time)
            parts += [s.vertices @ T[:3, :3].T + T[:3, 3] for s in mover.surfaces]
        return self._raycasting_scene(np.concatenate(parts))

    def cast(self, pose: np.ndarray, time: float, step: int = 1) -> Hits:
        """Intersect one ray per ``step``-th pixel from the camera at ``pose`` (T_world_camera)."""
        origin = pose[:3, 3].astype(np.float32)
        rays = np.empty(self._rays[step].shape[:-1] + (6,), np.float32)
        rays[..., :3] = origin
        rays[..., 3:] = rotate(self._rays[step], pose[:3, :3])
        directions = rays[..., 3:]
        result = self._scene_at(time).cast_rays(self.o3d.core.Tensor.from_numpy(rays), nthreads=self.threads)
        t_hit = result["t_hit"].numpy()
        hit = np.isfinite(t_hit)
        depth = np.where(hit, t_hit, np.float32(0.0))
        triangle = np.where(hit, result["primitive_ids"].numpy().astype(np.int64), -1)
        normal = result["primitive_normals"].numpy()
        dot = np.einsum("hwc,hwc->hw", normal, directions)
        normal *= np.where(dot > 0, np.float32(-1.0), np.float32(1.0))[..., None]
        cos = np.abs(dot) / self._ray_norms[step]
        points = origin + directions * depth[..., None]
        return Hits(depth, triangle, result["primitive_uvs"].numpy(), normal, cos, points)

    def albedo(self, hits: Hits) -> np.ndarray:
        """Trilinearly filtered texture colour per pixel, float32 ``(H, W, 3)``."""
        triangle = np.maximum(hits.triangle, 0)
        corners = np.take(self.corner_uv, triangle, axis=-1)  # (3, 2, H, W)
        b1, b2 = np.ascontiguousarray(np.moveaxis(hits.barycentric, -1, 0))
        x, y = corners[0] * (1 - b1 - b2) + corners[1] * b1 + corners[2] * b2
        footprint = hits.depth / (self.camera.fx * self.texel[triangle] * np.sqrt(np.maximum(hits.cos_incidence, 0.05)))
        level = np.clip(np.log2(np.maximum(footprint, 1e-6)), 0, MIP_LEVELS - 1)
        colour = np.zeros(hits.depth.shape + (3,), np.float32)
        for k, image in enumerate(self.levels):
            weight = np.clip(1.0 - np.abs(level - k), 0.0, 1.0)
            if not weight.any():
                continue
            scale = 0.5 ** k
            map_x = ((x + 0.5) * scale - 0.5).astype(np.float32)
            map_y = ((y + 0.5) * scale - 0.5).astype(np.float32)
            sample = cv2.remap(image, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
            colour += weight[..., None] * sample
        return colour

    def shade(self, hits: Hits) -> np.ndarray:
        """Lambertian shading from the scene's point lights; float32 RGB in [0, 255]."""
        light = np.zeros(hits.depth.shape, np.float32)
        # Coordinate planes rather than (H, W, 3) arrays: the same sums, on contiguous memory.
        points, normal = (np.ascontiguousarray(np.moveaxis(a, -1, 0)) for a in (hits.points, hits.normal))
        for position in self._lights:
            to_light = position.astype(np.float32)[:, None, None] - points
            squared = dot3(to_light, to_light)
            lambert = dot3(normal, to_light)
            light += np.maximum(lambert, 0.0) / (np.sqrt(squared) * (1.0 + squared / 25.0) + 1e-6)
        ambient = self.scene.ambient
        intensity = ambient + (1 - ambient) * 1.6 / len(self._lights) * light
        colour = self.albedo(hits) * intensity[..., None]
        colour[hits.triangle < 0] = self.scene.background
        return colour

    def colour(self, pose: np.ndarray, time: float) -> tuple[np.ndarray, Hits]:
        """The ideal colour image at ``pose`` and ``time``, with the full-resolution hits."""
        hits = self.cast(pose, time)
        return self.shade(hits), hits

    def depth(self, pose: np.ndarray, time: float) -> tuple[np.ndarray, np.ndarray]:
        """Ideal depth (metres, 0 on a miss) and incidence cosine at full resolution.

        Rays are cast on every second pixel; inverse depth, which is linear in the image
        on a plane, is interpolated between samples, and across depth edges the nearest
        sample is kept so that no point floats between foreground and background.
        """
        hits = self.cast(pose, time, DEPTH_STEP)
        inverse = np.where(hits.depth > 0, 1.0 / np.maximum(hits.depth, 1e-9), 0.0).astype(np.float32)
        padded = np.pad(inverse, 1, mode="reflect", reflect_type="odd")  # continues planes across the border
        bend = np.maximum(np.abs(padded[1:-1, :-2] - 2 * inverse + padded[1:-1, 2:]),
                          np.abs(padded[:-2, 1:-1] - 2 * inverse + padded[2:, 1:-1]))
        # A sample whose neighbours do not continue its plane marks the cells around it as edges.
        kink = (bend > 0.02 * inverse).astype(np.uint8)
        edge_cell = cv2.dilate(kink, np.ones((2, 2), np.uint8), anchor=(0, 0), borderType=cv2.BORDER_REPLICATE)
        smooth = cv2.remap(inverse, *self._half_maps, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        inverse_full = np.where(edge_cell[self._half_index] > 0, inverse[self._half_index], smooth)
        depth = np.where(inverse_full > 0, 1.0 / np.maximum(inverse_full, 1e-9), 0.0).astype(np.float32)
        return depth, hits.cos_incidence[self._half_index]
