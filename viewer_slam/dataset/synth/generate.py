"""Generate a scenario into a TUM folder, or once into the cache.

Randomness comes from independent streams of one seed (scene, timing, ground-truth noise,
and one per frame for the sensor), so the output is byte-identical for the same arguments
whatever the process that renders them. Long runs are rendered by this process together
with a pool of worker processes, each building the scene once from the seed and rendering
and encoding whole frames; this process writes the PNGs in frame order. Short runs stay
in-process (starting a worker costs more than rendering them), with PNGs encoded on a
thread while the next frame renders (OpenCV's encoder releases the GIL).

A run may be rendered only up to its first frames (``first``): frame i depends on the seed,
the scenario's length and i alone, so those frames are the full run's, byte for byte, and a
benchmark cut with ``--max-frames`` renders no frame it does not read.
"""

import contextlib
import functools
import multiprocessing
import os
import shutil
import tempfile
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor, ThreadPoolExecutor
from pathlib import Path

import cv2
import numpy as np

from ...atomic import check_name, writing
from ...cache import cache_dir
from ...documents import read_json
from ...errors import InputError
from ...geometry.camera import Camera
from ...geometry.trajectory import Trajectory
from ...progress import counted
from ...stopping import at_safe_points
from . import writer
from .catalog import MAX_FRAMES, SCENARIOS
from .render import Renderer
from .scenarios import SCENARIOS_BY_NAME, Plan
from .sensor import KinectModel, motion_blur
from .trajectories import noisy_groundtruth, sensor_timing

# Bump whenever the output for the same arguments changes: cached folders carry it in their name.
GENERATOR_VERSION = 7


# TUM's published intrinsics at 640x480 (fx, fy, cx, cy); images are rendered undistorted.
CAMERAS = {
    "fr1": (517.3, 516.5, 318.6, 255.3),
    "fr2": (520.9, 521.0, 325.1, 249.7),
    "fr3": (535.4, 539.2, 320.1, 247.6),
}

_SCENE, _TIMING, _GROUNDTRUTH, _SENSOR = range(4)  # seed streams
# Below this many pixels in a run (60 frames at 640x480), worker start-up (about 3 CPU seconds:
# imports and the scene) outweighs the gain.
_POOL_MIN_PIXELS = 60 * 640 * 480
_WRITTEN = ("rgb", "depth", "rgb.txt", "depth.txt", "groundtruth.txt", "camera.json", "scenario.json")


def default_frames(name: str) -> int:
    """Frames in a run of ``name`` when none are asked for (motion at the mirrored sequence's speed)."""
    return _scenario(name).default_frames


def camera_model(camera: str, resolution: tuple[int, int]) -> Camera:
    if camera not in CAMERAS:
        raise InputError(f"unknown camera {camera!r}; valid: {', '.join(CAMERAS)}")
    fx, fy, cx, cy = CAMERAS[camera]
    return Camera(fx, fy, cx, cy, 640, 480).scaled(*resolution)


def _scenario(name: str):
    if name not in SCENARIOS_BY_NAME:
        raise InputError(f"unknown scenario {name!r}; valid: {', '.join(SCENARIOS)}")
    return SCENARIOS_BY_NAME[name]


def _check(frames: int, resolution: tuple[int, int], seed: int) -> None:
    if not 2 <= frames <= MAX_FRAMES:
        raise InputError(f"frames must be from 2 to {MAX_FRAMES}, got {frames}")
    width, height = resolution
    if not (16 <= width <= 4096 and 16 <= height <= 4096):
        raise InputError(f"resolution {width}x{height} out of range; valid: WIDTHxHEIGHT from 16x16 to 4096x4096")
    if seed < 0:
        raise InputError(f"seed must be non-negative, got {seed}")


def generate_scenario(
    name: str,
    out_dir,
    *,
    frames: int | None = None,
    resolution: tuple[int, int] = (640, 480),
    seed: int = 0,
    camera: str = "fr3",
    force: bool = False,
    workers: int | None = None,
    first: int | None = None,
    progress: bool = False,
) -> Path:
    """Render scenario ``name`` into the TUM folder ``out_dir`` and return it.

    With ``first`` below ``frames``, only the run's first ``first`` frames are rendered and
    listed (the groundtruth stays whole, and scenario.json names them ``rendered_frames``).
    ``progress`` shows frames done, rate and time left on stderr.

    ``workers`` processes render the frames: this one and ``workers - 1`` spawned ones (at
    most one per frame); by default one per CPU, or only this one for a short run. The files
    do not depend on it.

    An existing non-empty ``out_dir`` is refused unless ``force``; then only what the
    generator writes is replaced. The folder is assembled beside ``out_dir`` and moved into
    place at the end, so an interrupted run leaves no half-written sequence.
    """
    scenario = _scenario(name)
    frames = scenario.default_frames if frames is None else int(frames)
    resolution = (int(resolution[0]), int(resolution[1]))
    _check(frames, resolution, seed)
    rendered = frames if first is None else min(int(first), frames)
    if rendered < 1:
        raise InputError(f"first must be at least 1, got {first}")
    cam = camera_model(camera, resolution)
    workers = _worker_count(workers, rendered, resolution)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError.at(out, "exists and is not a folder")
    if out.is_dir() and any(out.iterdir()) and not force:
        raise InputError.at(out, "folder exists and is not empty; use --force to overwrite")
    check_name(out)
    with writing(out):
        out.parent.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        run = _Run(scenario, frames, cam, seed)
        with (
            writing(out),
            at_safe_points() as stop,
            counted(f"rendering {name}", rendered, "frames", enabled=progress) as advance,
        ):

            def done() -> None:
                advance()
                stop.check()  # a stop signal ends the render here, between two frames

            run.write(staging, camera, workers, rendered, done)
        _publish(staging, out)
    finally:
        if staging.exists():
            shutil.rmtree(staging)
    return out


def _publish(staging: Path, out: Path) -> None:
    """Move the rendered folder into place: replace what the generator writes in ``out``, or
    rename the whole folder to ``out``."""
    with writing(out):
        if out.is_dir():
            for entry in _WRITTEN:
                target = out / entry
                if target.is_dir():
                    shutil.rmtree(target)
                elif target.exists():
                    target.unlink()
            for entry in _WRITTEN:
                os.replace(staging / entry, out / entry)
            staging.rmdir()
        else:
            os.replace(staging, out)


def cached_scenario(
    name: str,
    *,
    frames: int | None = None,
    resolution: tuple[int, int] = (640, 480),
    seed: int = 0,
    first: int | None = None,
    progress: bool = False,
) -> Path:
    """The folder of scenario ``name`` in the cache, generated on first use (fr3 camera).

    ``first`` asks for the run's first frames only: a complete run in the cache serves, else a
    cut of at least that many frames, else the cut is rendered into a folder of its own
    (``<run>-first<N>``), so a longer request never takes a short cut for the whole run.

    The run is rendered into a temporary folder and renamed into place, so a folder in the
    cache is always complete; when two processes race, the first rename wins.
    """
    frames = _scenario(name).default_frames if frames is None else int(frames)
    width, height = resolution
    root = cache_dir("synth")
    complete = root / f"{name}-{frames}-{width}x{height}-s{seed}-v{GENERATOR_VERSION}"
    if complete.is_dir():
        return complete
    final = complete
    if first is not None and first < frames:
        longer = sorted(found for found in cached_cuts(complete) if found[0] >= first)
        if longer:
            return longer[0][1]
        final = complete.with_name(f"{complete.name}-first{first}")
    staging = Path(tempfile.mkdtemp(prefix=f".{final.name}.", dir=root))
    try:
        generate_scenario(
            name,
            staging / "run",
            frames=frames,
            resolution=resolution,
            seed=seed,
            first=first if final != complete else None,
            progress=progress,
        )
        try:
            os.rename(staging / "run", final)
        except OSError:
            if not final.is_dir():
                raise
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return final


def cached_cuts(complete: Path) -> list[tuple[int, Path]]:
    """``(frames rendered, folder)`` of every cut of the run whose complete folder is ``complete``."""
    prefix = f"{complete.name}-first"
    return [
        (int(folder.name[len(prefix) :]), folder)
        for folder in complete.parent.glob(f"{prefix}*")
        if folder.name[len(prefix) :].isdigit() and folder.is_dir()
    ]


def _worker_count(workers: int | None, frames: int, resolution: tuple[int, int]) -> int:
    if workers is None:
        if frames * resolution[0] * resolution[1] < _POOL_MIN_PIXELS:
            return 1
        workers = os.cpu_count() or 1
    if workers < 1:
        raise InputError(f"workers must be at least 1, got {workers}")
    return min(workers, frames)


class _Run:
    """One run of a scenario: its plan, stamps, renderer, and the frames rendered on demand."""

    def __init__(self, scenario, frames: int, camera: Camera, seed: int):
        self.scenario, self.frames, self.camera, self.seed = scenario, frames, camera, seed
        self.plan: Plan = scenario.build(np.random.default_rng([seed, _SCENE]), frames)
        self.timing = sensor_timing(np.random.default_rng([seed, _TIMING]), frames)
        self.sensor = KinectModel()
        self.covered = np.zeros(frames, bool)
        for first, last in self.plan.covered:
            self.covered[first : last + 1] = True

    @functools.cached_property
    def renderer(self) -> Renderer:
        """Built on first use: a parent whose workers render needs only the plan."""
        return Renderer(self.plan.scene, self.camera)

    def frame(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Colour (uint8 RGB) and depth (float32 metres) of frame ``i``; black and empty while covered."""
        camera, plan, timing = self.camera, self.plan, self.timing
        if self.covered[i]:
            return np.zeros((camera.height, camera.width, 3), np.uint8), np.zeros(
                (camera.height, camera.width), np.float32
            )
        rng = np.random.default_rng([self.seed, _SENSOR, i])
        t_colour, t_depth = timing.colour[i] - timing.start, timing.depth[i] - timing.start
        half = plan.exposure / 2
        poses = plan.path.poses([t_colour, t_colour - half, t_colour + half, t_depth])
        ideal, hits = self.renderer.colour(poses[0], t_colour)
        if plan.exposure > 0:
            ideal = motion_blur(ideal, hits.grid_points, hits.grid_hit, camera, poses[1], poses[2])
        rgb = self.sensor.colour(rng, ideal)
        depth, cos_incidence = self.renderer.depth(poses[3], t_depth)
        return rgb, self.sensor.depth(rng, depth, cos_incidence)

    def encoded_frame(self, i: int) -> tuple[bytes, bytes]:
        return writer.encode_frame(*self.frame(i), self.camera.depth_factor)

    def encoded_frames(self, workers: int, count: int):
        """The PNGs of the first ``count`` frames, in order."""
        if workers == 1:
            yield from self._encoded_in_process(count)
            return
        # Spawned, not forked: a fork would inherit OpenCV's thread pool mid-state.
        with (
            _one_opencv_thread(),
            ProcessPoolExecutor(
                workers - 1,
                mp_context=multiprocessing.get_context("spawn"),
                initializer=_start_worker,
                initargs=(self.scenario.name, self.frames, self.camera, self.seed),
            ) as pool,
        ):
            yield from self._encoded_with(pool, workers - 1, count)

    def _encoded_with(self, pool: ProcessPoolExecutor, size: int, count: int):
        """Frames from the pool's ``size`` processes and from this one, which renders the next
        frame not yet handed out whenever the frame due is not ready: it works from the start,
        while the workers still import and build the scene, and takes over when they lag."""
        queued: dict[int, Future[tuple[bytes, bytes]]] = {}
        ready: dict[int, tuple[bytes, bytes]] = {}
        handed = 0
        for i in range(count):
            while i not in ready:
                while handed < count and sum(not f.done() for f in queued.values()) < 2 * size:
                    queued[handed] = pool.submit(_worker_frame, handed)
                    handed += 1
                if i in queued and (queued[i].done() or handed == count):
                    ready[i] = queued.pop(i).result()
                else:
                    ready[handed] = self.encoded_frame(handed)
                    handed += 1
            yield ready.pop(i)

    def _encoded_in_process(self, count: int):
        with ThreadPoolExecutor(max_workers=2) as pool:
            pending: deque[Future[tuple[bytes, bytes]]] = deque()
            for i in range(count):
                pending.append(pool.submit(writer.encode_frame, *self.frame(i), self.camera.depth_factor))
                if len(pending) > 3:
                    yield pending.popleft().result()
            while pending:
                yield pending.popleft().result()

    def write(self, folder: Path, camera_name: str, workers: int, count: int, done: Callable[[], None]) -> None:
        """The first ``count`` frames and the index files listing them; ``done`` after each frame."""
        timing, plan = self.timing, self.plan
        writer.prepare(folder)
        for i, (rgb_png, depth_png) in enumerate(self.encoded_frames(workers, count)):
            writer.write_frame(folder, timing.colour[i], rgb_png, timing.depth[i], depth_png)
            done()
        gt_poses = noisy_groundtruth(
            np.random.default_rng([self.seed, _GROUNDTRUTH]), plan.path.poses(timing.groundtruth - timing.start)
        )
        info = {
            "scenario": self.scenario.name,
            "seed": self.seed,
            "frames": self.frames,
            "resolution": [self.camera.width, self.camera.height],
            "camera": camera_name,
            "mirrors": self.scenario.info.mirrors,
            "tests": self.scenario.info.tests,
            "covered_intervals": [[float(timing.colour[a]), float(timing.colour[b])] for a, b in plan.covered],
            "loop": plan.loop,
            "notes": plan.notes,
            "generator_version": GENERATOR_VERSION,
        }
        if count < self.frames:
            info["rendered_frames"] = count
        source = f"viewslam synth {self.scenario.name} --frames {self.frames} --seed {self.seed}"
        writer.write_index(
            folder,
            source,
            timing.colour[:count],
            timing.depth[:count],
            Trajectory(timing.groundtruth, gt_poses),
            self.camera,
            info,
        )


_worker_run: _Run | None = None  # the run a pool worker renders frames of


@contextlib.contextmanager
def _one_opencv_thread():
    """OpenCV on one thread while this process renders beside its workers (restored after)."""
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        yield
    finally:
        cv2.setNumThreads(threads)


def _start_worker(name: str, frames: int, camera: Camera, seed: int) -> None:
    """Build the run once per worker; one thread each, as the workers already fill the cores."""
    global _worker_run
    cv2.setNumThreads(1)
    _worker_run = _Run(_scenario(name), frames, camera, seed)


def _worker_frame(i: int) -> tuple[bytes, bytes]:
    assert _worker_run is not None  # the pool's initializer, _start_worker, ran first in this worker
    return _worker_run.encoded_frame(i)


def preview_frames(
    name: str,
    fractions,
    *,
    frames: int | None = None,
    resolution: tuple[int, int] = (640, 480),
    seed: int = 0,
    camera: str = "fr3",
) -> list[tuple[int, np.ndarray, np.ndarray]]:
    """``(index, rgb, depth)`` of the frames at ``fractions`` (0 to 1) of a run, exactly as
    :func:`generate_scenario` would write them, without rendering the rest: a quick look.

    A covered frame is replaced by the next frame that is not covered.
    """
    scenario = _scenario(name)
    frames = scenario.default_frames if frames is None else int(frames)
    _check(frames, resolution, seed)
    run = _Run(scenario, frames, camera_model(camera, resolution), seed)
    visible = np.flatnonzero(~run.covered)
    picks = [int(visible[np.searchsorted(visible, min(round(f * (frames - 1)), visible[-1]))]) for f in fractions]
    return [(i, *run.frame(i)) for i in picks]


def read_info(folder) -> dict:
    """The ``scenario.json`` of a generated folder."""
    return read_json(Path(folder) / "scenario.json", "the scenario's description")
