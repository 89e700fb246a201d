"""The layout a recording opens with, read from the real viewer's pixels.

A tiny recording (40 frames of a scripted pipeline served as both rgbdslam and rtabmap, the
second with an error of its own so that their curves and paths part, mapping the walls of a
room as an RGB-D camera would) is opened by the Rerun
viewer under Xvfb at 1920x1080 and 1280x800: the 3D view must not be mostly empty (its
drawn content spread over most of it) and each pipeline's colour must show in it. The same
recording is served by `viewslam view --web` and drawn by a headless Chromium without a GPU
(its software rasteriser), watched over the DevTools protocol until it has drawn the
recording. Without xvfb-run, the viewer or chromium, those tests are skipped. The eye and the plots' lost bands
are checked without a viewer.
"""

import asyncio
import base64
import itertools
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
import types
import urllib.request
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scripted_circle import MAP_FROM_WORLD, ScriptedPipeline, write_tum_folder

from viewer_slam import palette
from viewer_slam.cli.view import free_port
from viewer_slam.geometry.se3 import make_pose, transform_points
from viewer_slam.pipelines import base
from viewer_slam.pipelines.events import FrameTracked, MapUpdated
from viewer_slam.record.command import record
from viewer_slam.rerun_adapter import blueprint
from viewer_slam.rerun_adapter.recorder import lost_colour

RERUN = Path(sys.executable).with_name("rerun")
VIEWSLAM = Path(sys.executable).with_name("viewslam")
PIPELINES = ("rgbdslam", "rtabmap")
# Share of the 3D view's cells (a 24 x 16 grid) that hold drawn content. The 200-frame fr1/rpy
# excerpt framed on its path's middle tenth with the rest black had 0.46; framed as now, 0.997.
MIN_OCCUPIED_CELLS = 0.7
needs_xvfb = pytest.mark.skipif(
    shutil.which("xvfb-run") is None or not RERUN.is_file(),
    reason="xvfb-run (Debian package xvfb) or the rerun viewer is missing",
)


def room_walls(rng: np.random.Generator, count: int) -> np.ndarray:
    """Points on the four walls and the floor of a 5 m x 5 m room around the camera's circle (world frame)."""
    u, v = rng.uniform(-2.5, 2.5, count), rng.uniform(-0.5, 2.0, count)
    wall = rng.integers(0, 5, count)
    return np.select(
        [wall[:, None] == k for k in range(5)],
        [
            np.stack([np.full(count, 2.5), u, v], axis=1),
            np.stack([np.full(count, -2.5), u, v], axis=1),
            np.stack([u, np.full(count, 2.5), v], axis=1),
            np.stack([u, np.full(count, -2.5), v], axis=1),
            np.stack([u, rng.uniform(-2.5, 2.5, count), np.full(count, -0.5)], axis=1),
        ],
    )


class RoomPipeline(ScriptedPipeline):
    """The scripted pipeline, its map the walls of a room rather than a blob around each keyframe."""

    def process(self, frame):
        walls = transform_points(MAP_FROM_WORLD, room_walls(np.random.default_rng(frame.index), 2000))
        return [
            MapUpdated(frame.index, walls, np.full(walls.shape, 150, np.uint8))
            if isinstance(event, MapUpdated)
            else event
            for event in super().process(frame)
        ]


class WobblingPipeline(RoomPipeline):
    """With an error that no rigid alignment removes: a 6 cm wobble."""

    def process(self, frame):
        events = super().process(frame)
        for event in events:
            if isinstance(event, FrameTracked) and event.pose is not None:
                event.pose[:3, 3] += 0.06 * np.array([np.sin(frame.index / 3), np.cos(frame.index / 4), 0.0])
        return events


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("layout")
    sequence = write_tum_folder(folder / "circle")
    with pytest.MonkeyPatch.context() as monkeypatch:
        for module_name, pipeline, name in (
            ("layout_steady", RoomPipeline, "rgbdslam"),
            ("layout_wobbling", WobblingPipeline, "rtabmap"),
        ):
            module = types.ModuleType(module_name)
            module.PIPELINE = pipeline
            monkeypatch.setitem(sys.modules, module_name, module)
            monkeypatch.setitem(base.PIPELINE_MODULES, name, module_name)
        return record(str(sequence), out=folder / "circle.rrd", quiet=True).recording


def rgb(path: Path) -> np.ndarray:
    image = cv2.imread(str(path))
    assert image is not None, path
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB).astype(int)


def scene_region(image: np.ndarray) -> np.ndarray:
    """Inside the 3D view, whatever the window's size: the left column's upper part, below its title."""
    height, width = image.shape[:2]
    return image[int(0.08 * height) : int(0.7 * height), int(0.01 * width) : int(0.55 * width)]


def occupied_cells(region: np.ndarray, rows: int = 16, columns: int = 24) -> float:
    """Share of the grid's cells of which at least 0.5 % of the pixels (a map point) differ from the background."""
    background = np.median(region.reshape(-1, 3), axis=0)
    drawn = np.abs(region - background).sum(axis=2) > 60
    height, width = drawn.shape[0] // rows * rows, drawn.shape[1] // columns * columns
    cells = drawn[:height, :width].reshape(rows, height // rows, columns, width // columns).mean(axis=(1, 3))
    return float((cells > 0.005).mean())


def pixels_of(image: np.ndarray, colour) -> int:
    return int(np.count_nonzero(np.abs(image - np.asarray(colour)).sum(axis=2) < 40))


def in_colour(image: np.ndarray) -> bool:
    """Panels drawn, not a blank or loading page: contrast and over 300 distinct colours."""
    return bool(image.std() > 20 and len(np.unique(image.reshape(-1, 3) // 8, axis=0)) > 300)


def assert_draws_every_pipeline(image: np.ndarray) -> None:
    assert in_colour(image)
    scene = scene_region(image)
    for position, name in enumerate(PIPELINES):  # its trajectory and frustum, in the 3D view
        assert pixels_of(scene, palette.run_colour(name, position).rgb) > 100, name


@needs_xvfb
@pytest.mark.parametrize("size", ["1920x1080", "1280x800"])
def test_the_3d_view_is_filled_and_shows_each_pipeline_at_both_window_sizes(recording, size, tmp_path):
    shot = tmp_path / "shot.png"
    # A screen wider than the window (drawn at twice its size) keeps the pointer, at the screen's
    # centre, off it; a port of its own keeps any viewer already running out of the way.
    done = subprocess.run(
        [
            "xvfb-run",
            "-a",
            "-s",
            "-screen 0 6600x2400x24",
            RERUN,
            "--port",
            str(free_port()),
            "--screenshot-to",
            shot,
            "--window-size",
            size,
            recording,
        ],
        capture_output=True,
        text=True,
        timeout=240,
        check=False,
    )
    assert done.returncode == 0 and shot.is_file(), done.stderr[-3000:]
    image = rgb(shot)
    width, height = map(int, size.split("x"))
    assert image.shape[0] >= height and image.shape[1] >= width
    assert_draws_every_pipeline(image)
    assert occupied_cells(scene_region(image)) >= MIN_OCCUPIED_CELLS


def chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


BROWSER_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--window-size=1600,900",
]


def page_socket(devtools_port: int) -> str:
    """The DevTools websocket of the browser's page."""
    with urllib.request.urlopen(f"http://127.0.0.1:{devtools_port}/json/list", timeout=10) as response:
        return next(target for target in json.load(response) if target["type"] == "page")["webSocketDebuggerUrl"]


async def screenshots(websocket: str, interval_s: float):
    """PNG screenshots of the browser's page, one every ``interval_s``, over the DevTools protocol."""
    import aiohttp

    async with aiohttp.ClientSession() as session, session.ws_connect(websocket, max_msg_size=0) as socket:
        for request in itertools.count(1):
            await asyncio.sleep(interval_s)
            await socket.send_json({"id": request, "method": "Page.captureScreenshot", "params": {"format": "png"}})
            while (reply := json.loads((await socket.receive()).data)).get("id") != request:
                pass
            yield base64.b64decode(reply["result"]["data"])


def browser_draws(
    address: str, profile: Path, shot: Path, done: Callable[[np.ndarray], bool], timeout_s: float = 180.0
) -> np.ndarray:
    """The page at ``address`` as a fresh headless Chromium draws it, once ``done(image)`` holds (or
    at the deadline): the web viewer loads its wasm, then the recording streams in, so on a loaded
    machine an early screenshot lacks part of it (one pipeline's panels still empty)."""
    browser = subprocess.Popen(
        [chromium(), *BROWSER_FLAGS, f"--user-data-dir={profile}", "--remote-debugging-port=0", address],
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        port = next(
            match.group(1)
            for line in browser.stderr
            if (match := re.search(r"DevTools listening on ws://127\.0\.0\.1:(\d+)/", line))
        )

        websocket = page_socket(int(port))

        async def watch() -> np.ndarray:
            deadline = time.monotonic() + timeout_s
            async for png in screenshots(websocket, 2.0):
                shot.write_bytes(png)
                image = rgb(shot)
                if done(image) or time.monotonic() > deadline:
                    return image

        return asyncio.run(watch())
    finally:
        os.killpg(browser.pid, signal.SIGTERM)
        browser.wait(timeout=30)


def web_page_drawn(image: np.ndarray) -> bool:
    """The whole page is drawn: its panels in colour, each pipeline's path and frustum in 3D and its
    curves, and the ground truth in the 3D view."""
    return (
        in_colour(image)
        and all(pixels_of(image, palette.run_colour(name, i).rgb) > 100 for i, name in enumerate(PIPELINES))
        and pixels_of(scene_region(image), palette.GROUNDTRUTH.rgb) > 50
    )


@pytest.mark.skipif(chromium() is None, reason="chromium (Debian package chromium) is not installed")
def test_view_web_is_drawn_by_a_headless_browser(recording, tmp_path):
    pytest.importorskip("aiohttp")
    environment = {key: value for key, value in os.environ.items() if key not in ("DISPLAY", "WAYLAND_DISPLAY")}
    server = subprocess.Popen(
        [VIEWSLAM, "view", str(recording), "--web"],
        stdout=subprocess.PIPE,
        text=True,
        env=environment,
        start_new_session=True,
    )
    try:
        address = re.search(r"http://127\.0\.0\.1:\d+/\S*", server.stdout.readline())
        assert address
        # No GPU: the web viewer draws with the browser's software rasteriser.
        shot = tmp_path / "web.png"
        assert web_page_drawn(browser_draws(address.group(0), tmp_path / "profile", shot, web_page_drawn)), shot
    finally:
        os.killpg(server.pid, signal.SIGTERM)
        server.wait(timeout=30)


def angular_size(eye, positions: np.ndarray) -> float:
    """The largest angle between the eye's view axis and the direction to a position, degrees."""
    position, target = (
        np.asarray(getattr(eye, field).as_arrow_array()[0].values.to_numpy(zero_copy_only=False), dtype=float)
        for field in ("position", "look_target")
    )
    axis = (target - position) / np.linalg.norm(target - position)
    directions = positions - position
    cosines = directions @ axis / np.linalg.norm(directions, axis=1)
    return float(np.degrees(np.arccos(np.clip(cosines, -1, 1))).max())


def path(scale: float, heading_deg: float = 30.0) -> np.ndarray:
    """Camera poses along a curved path of about ``scale`` metres, looking ``heading_deg`` off +x."""
    t = np.linspace(0.0, 1.0, 50)
    positions = scale * np.stack([t, 0.4 * np.sin(3 * t), 0.1 * t], axis=1)
    rotation = (
        Rotation.from_rotvec(np.array([0.0, 0.0, np.radians(heading_deg)])).as_matrix()
        @ Rotation.from_rotvec(np.array([0.0, np.pi / 2, 0.0])).as_matrix()
    )
    return np.stack([make_pose(rotation, p) for p in positions])


def test_the_eye_keeps_the_whole_path_in_view_from_a_desk_to_a_hall():
    for scale in (0.12, 0.9, 7.0, 30.0):
        poses = path(scale)
        eye = blueprint.overview_eye(poses)
        assert angular_size(eye, poses[:, :3, 3]) <= blueprint.EYE_HALF_ANGLE_DEG + 1e-6
    # A large path fills its view as much as a room-sized one (the distance scales with it), and a
    # desk path is framed with the scene around it: no closer than the floor.
    room, hall = (angular_size(blueprint.overview_eye(path(s)), path(s)[:, :3, 3]) for s in (2.0, 30.0))
    assert hall == pytest.approx(room, rel=0.2)
    desk = angular_size(blueprint.overview_eye(path(0.12)), path(0.12)[:, :3, 3])
    assert 2.0 < desk < room


def test_lost_runs_keep_their_own_hue_and_their_bands_nest():
    colours = [lost_colour(palette.run_colour(name, i)) for i, name in enumerate(PIPELINES)]
    assert len(set(colours)) == 2 and palette.LOST.rgb not in colours
    widths = blueprint.lost_band_widths(3)
    assert widths[0] == blueprint.LOST_BAND_WIDTH and widths == sorted(widths, reverse=True)
