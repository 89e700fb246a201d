"""Generation speed of the synthetic scenarios, and the contact sheet of docs/scenarios.md.

    python -m benchmarks.synth [--frames 150] [--resolution 640x480]
        [--scenarios NAME ...] [--workers 2] [--sheet docs/images/scenarios_contact_sheet.png] [--no-speed]
        [--stages SCENARIO]

For each scenario: the steady frame rate (rendering, sensor model, PNG encoding), from the
difference between a run of ``--frames`` and one of half as many (both start the same
worker processes), in wall-clock time and in CPU time per frame (all threads of the process
and of its workers); the set-up time (imports and scene in the workers) as the rest of the
longer run; medians over ``--repeats`` runs. The
machine's load average is printed with the figures: on a shared machine the wall-clock
rate reflects the share of the cores the run got, while 2 / (CPU seconds per frame) is the
rate two idle cores would give at best. ``--stages`` splits the CPU time of one
scenario's frames by stage (in-process, on one thread as a worker runs).
"""

import argparse
import os
import statistics
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

import viewer_slam.code_paths  # noqa: F401  (before NumPy loads: holds it to one code path)

import cv2
import numpy as np

from viewer_slam.cli.options import parse_resolution
from viewer_slam.dataset.synth import SCENARIOS, generate_scenario, preview_frames

from . import lab


def cpu_seconds() -> float:
    """CPU time of this process's threads and of its finished worker processes."""
    times = os.times()
    return times.user + times.system + times.children_user + times.children_system


def timed_run(name, frames, resolution, folder, workers) -> tuple[float, float]:
    """Wall-clock and CPU seconds of one generation."""
    wall, cpu = time.perf_counter(), cpu_seconds()
    generate_scenario(name, folder, frames=frames, resolution=resolution, force=True, workers=workers)
    return time.perf_counter() - wall, cpu_seconds() - cpu


def contact_sheet(names, out: Path, resolution, fractions=(0.2, 0.5, 0.8), tile_width: int = 240) -> None:
    """A grid: one row per scenario at its default length, frames at ``fractions`` of the run,
    colour beside depth (rendered alone with ``preview_frames``, as a full run writes them)."""
    rows = []
    for name in names:
        tiles = []
        for _, rgb, depth in preview_frames(name, fractions, resolution=resolution):
            height = int(tile_width * rgb.shape[0] / rgb.shape[1])
            colour = cv2.resize(
                cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), (tile_width, height), interpolation=cv2.INTER_AREA
            )
            coloured = cv2.applyColorMap(np.clip(depth / 5.0 * 255, 0, 255).astype(np.uint8), cv2.COLORMAP_TURBO)
            coloured[depth == 0] = 0
            tiles += [colour, cv2.resize(coloured, (tile_width, height), interpolation=cv2.INTER_NEAREST)]
        row = np.hstack(tiles)
        label = np.full((22, row.shape[1], 3), 255, np.uint8)
        cv2.putText(
            label,
            f"{name}   (colour | depth 0-5 m, black = none)",
            (6, 16),
            cv2.FONT_HERSHEY_SIMPLEX,
            0.5,
            (0, 0, 0),
            1,
            cv2.LINE_AA,
        )
        rows += [label, row]
    out.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(out), np.vstack(rows), [cv2.IMWRITE_PNG_COMPRESSION, 9])


def measure_speed(names, frames: int, resolution, repeats: int, workers: int) -> None:
    """Per scenario: runs of ``frames`` and of half as many; the difference is steady rendering.

    Both runs start the same workers, and this process renders from the start while they
    import and build the scene, so only the difference between the runs isolates the steady
    rate; set-up is the rest of the longer run's time.
    """
    print(
        f"load average before: {os.getloadavg()[0]:.2f}; {frames} frames at {resolution[0]}x{resolution[1]}, "
        f"{workers} worker(s)"
    )
    print(f"{'scenario':40s} {'setup s':>8s} {'frames/s':>9s} {'CPU s/frame':>12s} {'overall frames/s':>17s}")
    rates, cpu_per_frame, short = [], [], max(2, frames // 2)
    with tempfile.TemporaryDirectory() as scratch:
        for name in names:
            half = [timed_run(name, short, resolution, Path(scratch) / "half", workers) for _ in range(repeats)]
            total = [timed_run(name, frames, resolution, Path(scratch) / name, workers) for _ in range(repeats)]
            (half_wall, half_cpu), (total_wall, total_cpu) = (
                tuple(statistics.median(run[k] for run in runs) for k in (0, 1)) for runs in (half, total)
            )
            steady = (frames - short) / max(total_wall - half_wall, 1e-9)
            cpu = (total_cpu - half_cpu) / (frames - short)
            setup = max(total_wall - frames / steady, 0.0)
            rates.append(steady)
            cpu_per_frame.append(cpu)
            print(f"{name:40s} {setup:8.2f} {steady:9.1f} {cpu:12.3f} {frames / total_wall:17.1f}", flush=True)
    cpu = statistics.median(cpu_per_frame)
    print(
        f"median steady frames/s: {statistics.median(rates):.1f}; median CPU s/frame: {cpu:.3f} "
        f"(two idle cores: at most {2 / cpu:.1f} frames/s); load average after: {os.getloadavg()[0]:.2f}"
    )


@contextmanager
def timed(totals: dict[str, float], stage: str):
    start = time.process_time()
    yield
    totals[stage] = totals.get(stage, 0.0) + time.process_time() - start


def stage_profile(name: str, resolution, frames: int = 12) -> None:
    """CPU milliseconds per frame of each stage, over ``frames`` frames spread evenly over the
    uncovered part of a default-length run, on one thread as a rendering worker runs them."""
    from viewer_slam.dataset.synth import writer
    from viewer_slam.dataset.synth.generate import _Run, _scenario, camera_model
    from viewer_slam.dataset.synth.sensor import motion_blur

    cv2.setNumThreads(1)
    scenario = _scenario(name)
    run = _Run(scenario, scenario.default_frames, camera_model("fr3", resolution), seed=0)
    plan, renderer, sensor, camera = run.plan, run.renderer, run.sensor, run.camera
    totals: dict[str, float] = {}
    visible = np.flatnonzero(~run.covered)
    run.frame(int(visible[0]))  # loads the compiled ray caster, which is no stage of a frame
    for i in visible[np.linspace(0, len(visible) - 1, frames).round().astype(int)]:
        t, t_depth = run.timing.colour[i] - run.timing.start, run.timing.depth[i] - run.timing.start
        poses = plan.path.poses([t, t - plan.exposure / 2, t + plan.exposure / 2, t_depth])
        rng = np.random.default_rng(int(i))
        with timed(totals, "ray casting"):
            hits = renderer.cast(poses[0], t)
        with timed(totals, "texture lookup and shading"):
            ideal = renderer.shade(hits, poses[0], t)
        with timed(totals, "motion blur"):
            ideal = motion_blur(ideal, hits.grid_points, hits.grid_hit, camera, poses[1], poses[2])
        with timed(totals, "colour noise"):
            rgb = sensor.colour(rng, ideal)
        with timed(totals, "depth cast"):
            ideal_depth, cos_incidence = renderer.depth(poses[3], t_depth)
        with timed(totals, "depth noise"):
            depth = sensor.depth(rng, ideal_depth, cos_incidence)
        with timed(totals, "PNG encoding"):
            writer.encode_frame(rgb, depth, camera.depth_factor)
    print(f"CPU ms per frame by stage ({name}, {resolution[0]}x{resolution[1]}, {frames} frames):")
    for stage, seconds in totals.items():
        print(f"  {stage:28s} {1000 * seconds / frames:7.1f}")
    print(f"  {'total':28s} {1000 * sum(totals.values()) / frames:7.1f}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.synth", description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=150)
    parser.add_argument("--resolution", default="640x480")
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--workers", type=int, default=os.cpu_count(), help="rendering processes (1: in-process)")
    parser.add_argument("--scenarios", nargs="*", default=list(SCENARIOS))
    parser.add_argument("--sheet", type=Path, help="also write the contact sheet (PNG) of the scenarios")
    parser.add_argument("--no-speed", action="store_true", help="skip the speed measurement")
    parser.add_argument("--stages", metavar="SCENARIO", help="also time each stage of rendering SCENARIO's frames")
    args = parser.parse_args(argv)
    resolution = parse_resolution(args.resolution)
    if not args.no_speed:
        measure_speed(args.scenarios, args.frames, resolution, args.repeats, args.workers)
    if args.stages:
        stage_profile(args.stages, resolution)
    if args.sheet:
        contact_sheet(args.scenarios, args.sheet, resolution)
        print(f"contact sheet: {args.sheet}")
    return 0


if __name__ == "__main__":
    lab.main_of(main)
