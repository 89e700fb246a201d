"""What a recording costs: size per frame, time next to the pipelines', peak memory.

    python benchmarks/record.py [--scenario 360_kidnap] [--frames 200] [--memory-frames 2500]

1. Size and time: records ``--frames`` frames of a synthetic scenario at 640x480 with both
   pipelines. Size is the .rrd's bytes per frame. Time is measured two ways: the time spent
   inside the recorder's calls (events, images, evaluation series) as a share of the
   pipelines' own time, and the wall time of `record` against the same pipelines run with
   no sink at all (this also charges Rerun's background encoder and writer threads).
2. Memory: both pipelines recorded over ``--memory-frames`` frames in a child process,
   which reports its peak RSS. Rendering thousands of synthetic frames takes longer than
   the measurement itself, so the long sequence plays the short one forwards, backwards,
   forwards... (continuous motion, time running on, groundtruth following the frames).
   ``--memory-frames 0`` skips it.

Prints the figures as JSON and writes their table into docs/recording.md (the figure block
``record-cost``), stamped with the command, the machine, the load before the run and the date:
too costly for the test suite, so never re-run there.
"""

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import viewer_slam.code_paths  # noqa: F401  (before NumPy loads: holds it to one code path)

import numpy as np

from viewer_slam.dataset.frame import Frame, select_frames
from viewer_slam.dataset.sources import open_source
from viewer_slam.dataset.synth import cached_scenario
from viewer_slam.dataset.tum import TumSequence
from viewer_slam.geometry.trajectory import Trajectory
from viewer_slam.pipelines.base import PIPELINE_MODULES, make_pipeline
from viewer_slam.pipelines.run import run_pipeline
from viewer_slam.record import session
from viewer_slam.record.options import RecordOptions
from viewer_slam.record.session import record, record_sequence

RESOLUTION = (640, 480)
REPO = Path(__file__).resolve().parent.parent
DOCUMENT = REPO / "docs" / "recording.md"
sys.path.insert(0, str(REPO / "scripts"))
from doc_figures import stamp, with_block  # noqa: E402  (a script beside this one, not a package)


class Stopwatch:
    """Accumulates the time spent in the functions it wraps."""

    def __init__(self):
        self.seconds = 0.0

    def wrap(self, function):
        def timed(*args, **kwargs):
            start = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                self.seconds += time.perf_counter() - start
        return timed


def timed_recording(folder: Path, frames: int, out: Path) -> tuple[dict, float, float]:
    """Record with every recorder entry point timed; (report, recorder seconds, wall seconds)."""
    watch = Stopwatch()
    recorder_class = session.PipelineRecorder

    class TimedRecorder(recorder_class):
        __call__ = watch.wrap(recorder_class.__call__)
        begin_frame = watch.wrap(recorder_class.begin_frame)

    originals = (session.PipelineRecorder, session.log_frame_image, session.log_evaluation)
    session.PipelineRecorder = TimedRecorder
    session.log_frame_image = watch.wrap(session.log_frame_image)
    session.log_evaluation = watch.wrap(session.log_evaluation)
    try:
        start = time.perf_counter()
        result = record(RecordOptions(sequence=str(folder), out=out, max_frames=frames, quiet=True))
        wall = time.perf_counter() - start
    finally:
        session.PipelineRecorder, session.log_frame_image, session.log_evaluation = originals
    return result.report, watch.seconds, wall


def bare_pipelines(folder: Path, frames: int) -> float:
    sequence = open_source(folder)
    start = time.perf_counter()
    for name in PIPELINE_MODULES:
        run_pipeline(sequence, name, max_frames=frames)
    return time.perf_counter() - start


class PingPong:
    """``length`` frames of ``sequence`` played forwards, backwards, forwards, ... at its frame rate."""

    def __init__(self, sequence: TumSequence, length: int):
        period = 2 * len(sequence) - 2
        step = np.arange(length)
        phase = step % period
        self._sequence = sequence
        self._source = np.where(phase < len(sequence), phase, period - phase)
        self.timestamps = sequence.timestamps[0] + step * np.median(np.diff(sequence.timestamps))
        poses, _ = sequence.groundtruth_at(sequence.timestamps[self._source])
        self.groundtruth = Trajectory(self.timestamps, poses)
        self.name, self.path, self.camera = f"{sequence.name}-pingpong-{length}", sequence.path, sequence.camera

    def __len__(self) -> int:
        return len(self.timestamps)

    @property
    def duration_s(self) -> float:
        return float(self.timestamps[-1] - self.timestamps[0])

    def frames(self, max_frames=None, stride=1):
        for index in select_frames(len(self), max_frames, stride):
            source = self._sequence.frame(int(self._source[index]))
            yield Frame(index, float(self.timestamps[index]), source.rgb, source.depth)


def measure_memory(folder: Path, frames: int, out: Path) -> None:
    """Child process: record both pipelines over the ping-pong sequence, print peak RSS in GiB."""
    sequence = PingPong(open_source(folder), frames)
    runs = {name: make_pipeline(name, sequence.camera) for name in PIPELINE_MODULES}
    result = record_sequence(sequence, runs, out, RecordOptions(quiet=True))
    print(json.dumps({"peak_rss_gib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20,
                      "kib_per_frame": out.stat().st_size / 1024 / frames,
                      "fps": {name: block["timing"]["fps"] for name, block in result.report["pipelines"].items()}}))


def peak_memory(folder: Path, frames: int, out: Path) -> dict:
    command = [sys.executable, __file__, "--memory-child", str(folder), "--memory-frames", str(frames),
               "--out", str(out)]
    return json.loads(subprocess.run(command, check=True, capture_output=True, text=True).stdout)


def table(results: dict) -> str:
    """The figures as docs/recording.md shows them, beside their targets."""
    frames = results["frames"]
    rows = [("| figure | measured | target |", "|---|---|---|"),
            (f"| size, {frames} frames, both pipelines | **{results['kib_per_frame']:.1f} KiB per frame** "
             f"({results['kib_per_frame'] * frames / 1024:.1f} MiB) | ≤ 60 KiB |",),
            (f"| time inside the recorder / pipelines' own time, {frames} frames | "
             f"**{results['recorder_share_of_pipelines']:.1%}** ({results['recorder_s']:.2f} s of "
             f"{results['pipelines_s']:.2f} s) | ≤ 25 % |",),
            (f"| wall time of `record` / the same pipelines with no sink, {frames} frames | "
             f"**{results['wall_overhead']:+.1%}** ({results['record_wall_s']:.2f} s against "
             f"{results['bare_pipelines_wall_s']:.2f} s) | |",)]
    memory = results.get("memory")
    if memory:
        rows += [(f"| size, {memory['frames']:,} frames, both pipelines | **{memory['kib_per_frame']:.1f} KiB per "
                  f"frame** ({memory['kib_per_frame'] * memory['frames'] / 1024:.0f} MiB) | ≤ 60 KiB |",),
                 (f"| peak RSS, {memory['frames']:,} frames, both pipelines, one process | "
                  f"**{memory['peak_rss_gib']:.2f} GiB** | ≤ 3 GB |",)]
    def rates(fps: dict[str, float]) -> str:
        return " and ".join(f"{name} {value:.1f}" for name, value in fps.items())

    text = f"Frames/s while recording {frames} frames: {rates(results['fps'])}"
    if memory:
        text += f"; {memory['frames']:,} frames: {rates(memory['fps'])}"
    return "\n".join(line for row in rows for line in row) + f"\n\n{text}."


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="360_kidnap")
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--memory-frames", type=int, default=2500)
    parser.add_argument("--memory-child", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--out", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.memory_child:
        measure_memory(args.memory_child, args.memory_frames, args.out)
        return

    load = os.getloadavg()[0]
    results = {"scenario": args.scenario, "resolution": list(RESOLUTION), "frames": args.frames}
    with tempfile.TemporaryDirectory() as scratch:
        folder = cached_scenario(args.scenario, frames=args.frames, resolution=RESOLUTION)
        out = Path(scratch) / "size.rrd"
        report, recorder_s, record_wall_s = timed_recording(folder, args.frames, out)
        pipeline_s = sum(block["timing"]["total_s"] for block in report["pipelines"].values()) - recorder_s
        bare_s = bare_pipelines(folder, args.frames)
        print(f"size and time done: {out.stat().st_size / 1024 / args.frames:.1f} KiB/frame", file=sys.stderr)
        results.update({
            "kib_per_frame": out.stat().st_size / 1024 / args.frames,
            "recorder_s": recorder_s,
            "pipelines_s": pipeline_s,
            "recorder_share_of_pipelines": recorder_s / pipeline_s,
            "record_wall_s": record_wall_s,
            "bare_pipelines_wall_s": bare_s,
            "wall_overhead": record_wall_s / bare_s - 1.0,
            "fps": {name: block["timing"]["fps"] for name, block in report["pipelines"].items()},
        })
        if args.memory_frames:
            results["memory"] = {"frames": args.memory_frames,
                                 **peak_memory(folder, args.memory_frames, Path(scratch) / "memory.rrd")}
    print(json.dumps(results, indent=2))
    command = " ".join(["python benchmarks/record.py", *sys.argv[1:]])
    DOCUMENT.write_text(with_block(DOCUMENT.read_text(), "record-cost",
                                   f"{stamp(command)} Load average {load:.1f} before the run.\n\n{table(results)}"))


if __name__ == "__main__":
    main()
