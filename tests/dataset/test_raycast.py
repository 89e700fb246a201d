"""The renderer's ray caster: exact hits worked out by hand, the tiles never changing a hit
(against every triangle tested for every ray), and machine code that rounds the same on
every x86-64 CPU (no fused multiply-add, no approximate reciprocal)."""

import re

import numba
import numpy as np
import pytest

from viewer_slam.dataset.synth import raycast
from viewer_slam.dataset.synth.generate import camera_model
from viewer_slam.dataset.synth.raycast import NEAR, TILE, TriangleCaster

CAMERA = camera_model("fr3", (160, 120))
IDENTITY = np.eye(4)


def pixel_grid(camera, step=1, beyond=0):
    rows, cols = np.indices(((camera.height + beyond) // step, (camera.width + beyond) // step)) * step
    return np.stack([cols.ravel(), rows.ravel()], -1).astype(np.float64)


def test_a_square_facing_the_camera_is_hit_at_its_depth_with_the_barycentric_weights_of_the_hit_point():
    # Two triangles of a square 2 m ahead, corners (-1, -1), (1, -1), (1, 1) | (-1, -1), (1, 1), (-1, 1).
    vertices = np.array([[-1.0, -1.0, 2.0], [1.0, -1.0, 2.0], [1.0, 1.0, 2.0], [-1.0, 1.0, 2.0]])
    caster = TriangleCaster(np.array([[0, 1, 2], [0, 2, 3]]), CAMERA)
    # A pixel's ray with unit depth runs through ((col - cx) / fx, (row - cy) / fy, 1): at 2 m, twice that.
    pixels = np.array([[80.0, 60.0], [90.0, 30.0], [70.0, 100.0]])
    hits = caster.frame(vertices, IDENTITY).cast(pixels)
    assert np.all(hits.t == 2.0)
    x, y = 2 * (pixels[:, 0] - CAMERA.cx) / CAMERA.fx, 2 * (pixels[:, 1] - CAMERA.cy) / CAMERA.fy
    corners = np.array([[0, 1, 2], [0, 2, 3]])
    for k in range(len(pixels)):
        # The first triangle holds the square's points with y <= x, the second the others.
        assert hits.triangle[k] == (0 if y[k] <= x[k] else 1)
        a, b, c = vertices[corners[hits.triangle[k]]]
        point = a + hits.barycentric[k, 0] * (b - a) + hits.barycentric[k, 1] * (c - a)
        assert np.allclose(point, [x[k], y[k], 2.0], rtol=0, atol=1e-12)


def test_the_nearest_hit_wins_the_lower_index_on_a_tie_and_nothing_behind_the_near_plane_counts():
    near_wall = np.array([[-5.0, -5.0, 3.0], [5.0, -5.0, 3.0], [0.0, 5.0, 3.0]])
    far_wall = near_wall + [0.0, 0.0, 1.0]
    behind = near_wall * [1.0, 1.0, -1.0]
    vertices = np.concatenate([far_wall, near_wall, near_wall, behind])
    triangles = np.arange(12).reshape(4, 3)
    hits = TriangleCaster(triangles, CAMERA).frame(vertices, IDENTITY).cast(np.array([[80.0, 60.0]]))
    assert hits.triangle[0] == 1 and hits.t[0] == 3.0
    grazing = np.array([[-5.0, -5.0, NEAR / 2], [5.0, -5.0, NEAR / 2], [0.0, 5.0, NEAR / 2]])
    hits = TriangleCaster(np.array([[0, 1, 2]]), CAMERA).frame(grazing, IDENTITY).cast(np.array([[80.0, 60.0]]))
    assert hits.triangle[0] == -1 and np.isinf(hits.t[0])


def every_triangle_for_every_ray(vertices, triangles, pose, pixels):
    """The nearest hit with no tiles: every ray tested against every triangle."""
    caster = TriangleCaster(triangles, CAMERA)
    frame = caster.frame(vertices, pose)
    tiles = frame.tiles.start.size - 1
    every = raycast.Tiles(
        np.arange(tiles + 1) * len(triangles), np.tile(np.arange(len(triangles)), tiles), frame.tiles.columns
    )
    return raycast.CasterFrame(
        caster, frame.rotation, frame.centre, frame.origin, frame.edge1, frame.edge2, every
    ).cast(pixels)


@pytest.mark.parametrize("seed", range(6))
def test_tiles_change_which_triangles_are_tested_never_the_hit(seed):
    rng = np.random.default_rng(seed)
    # Triangles around the camera, many crossing the near plane or behind it, some large, some tiny.
    centres = rng.uniform(-3, 3, (300, 3))
    sizes = rng.choice([0.05, 0.5, 4.0], 300)[:, None, None]
    vertices = (centres[:, None] + sizes * rng.normal(size=(300, 3, 3))).reshape(-1, 3)
    triangles = np.arange(900).reshape(300, 3)
    angle = rng.uniform(-np.pi, np.pi)
    pose = np.eye(4)
    pose[:3, :3] = [[np.cos(angle), 0, np.sin(angle)], [0, 1, 0], [-np.sin(angle), 0, np.cos(angle)]]
    pose[:3, 3] = rng.uniform(-0.5, 0.5, 3)
    pixels = pixel_grid(CAMERA, beyond=TILE)  # past the last row and column too, as the coarse grid reaches
    tiled = TriangleCaster(triangles, CAMERA).frame(vertices, pose).cast(pixels)
    brute = every_triangle_for_every_ray(vertices, triangles, pose, pixels)
    assert (tiled.triangle >= 0).mean() > 0.3
    assert np.array_equal(tiled.triangle, brute.triangle)
    assert np.array_equal(tiled.t, brute.t) and np.array_equal(tiled.barycentric, brute.barycentric)


def machine_code(function) -> str:
    """The function compiled afresh for this CPU (cached code cannot be inspected)."""
    fresh = numba.njit(nogil=True, error_model="numpy")(function.py_func)
    caster = TriangleCaster(np.array([[0, 1, 2]]), CAMERA)
    vertices = np.array([[-1.0, -1.0, 2.0], [1.0, -1.0, 2.0], [0.0, 1.0, 2.0]])
    frame = caster.frame(vertices, IDENTITY)
    if function is raycast._cast:
        fresh(
            np.array([80.0]),
            np.array([60.0]),
            frame.rotation,
            frame.centre,
            CAMERA.fx,
            CAMERA.fy,
            CAMERA.cx,
            CAMERA.cy,
            frame.origin,
            frame.edge1,
            frame.edge2,
            frame.tiles.start,
            frame.tiles.items,
            frame.tiles.columns,
            TILE,
            NEAR,
        )
    else:
        fresh(
            vertices,
            caster.triangles,
            frame.rotation,
            frame.centre,
            CAMERA.fx,
            CAMERA.fy,
            CAMERA.cx,
            CAMERA.cy,
            8,
            10,
            TILE,
            NEAR,
        )
    return "\n".join(fresh.inspect_asm().values())


@pytest.mark.parametrize("function", [raycast._cast, raycast._tile_ranges], ids=["cast", "tile_ranges"])
def test_the_compiled_caster_neither_fuses_nor_approximates(function):
    code = machine_code(function)
    assert re.search(r"\bv?mulsd\b|\bv?mulpd\b", code)  # the products are there, as products
    assert not re.findall(r"\bv?f(?:n)?m(?:add|sub)\w*\b|\bv?rcp\w*\b|\bv?rsqrt\w*\b", code)
