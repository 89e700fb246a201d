"""How much the odometry's local bundle adjustment trusts depth, and what that does to its pose.

    python -m benchmarks.odometry_adjustment FOLDER ... [--render SCENE:SEED ...] [--out DIR]
                                             [--frames N] [--seeds N] [--docs]

RTAB-Map built with g2o (the study's build, our defaults) refines each odometry registration
by a local bundle adjustment (OdomF2M/BundleAdjustment 1) and leaves RANSAC's pose otherwise
unrefined (Vis/PnPRefineIterations 0); built without g2o (the 0.23.8 oracle here) it refines
the pose once by PnP on the inliers. The adjustment sees a point's depth only through the fake
stereo of g2o/Baseline: a measured depth ``z`` is the disparity ``fx b / z`` pixels, weighed as
one pixel of g2o/PixelVariance, so it holds the depth to about ``z² / (fx b)`` metres. Near
the camera that is centimetres; at a scene's 3-4 m it is decimetres, and the adjustment then
fits the pose to the corners alone across key frames a few centimetres apart.

For each TUM folder (and each scene ``--render`` draws, into the oracle's cache ``--out``),
the first ``--frames`` frames go through our frame-to-map odometry in three configurations:
the g2o build, the build without g2o (the oracle's odometry), and the g2o build with the depth
held ten times tighter (g2o/Baseline 0.75: a probe of the mechanism, no one's default). Each
with pipeline seeds ``0..N-1``: the odometry's RPE over one frame and its ATE (rigid
alignment), ranges over the seeds, beside the median depth of the folder's depth images.
"""

import argparse
import statistics
from pathlib import Path

import viewer_slam.code_paths  # noqa: F401  (before NumPy loads: holds it to one code path)

import numpy as np

from viewer_slam.dataset.sources import RgbdSequence, open_source
from viewer_slam.errors import InputError
from viewer_slam.evaluation import evaluate
from viewer_slam.evaluation.rpe import DeltaUnit

from . import lab
from .figures import REPO, invocation, stamp, write_block
from .oracle import render, spread

DOCUMENT = REPO / "docs" / "pipelines" / "rtabmap.md"
BLOCK = "odometry-adjustment"
CONFIGURATIONS: dict[str, dict[str, float]] = {
    "g2o build (our defaults)": {},
    "without g2o (the oracle's)": {"OdomF2M/BundleAdjustment": 0, "Vis/PnPRefineIterations": 1},
    "g2o build, g2o/Baseline 0.75": {"g2o/Baseline": 0.75},
}
DEPTH_SAMPLES = 10  # depth images read for the median depth, spread over the frames


def median_depth(sequence: RgbdSequence, frames: int) -> float:
    """Median of the valid depth (m) over DEPTH_SAMPLES images among the first ``frames``."""
    stride = max(1, min(frames, len(sequence)) // DEPTH_SAMPLES)
    depth = [frame.depth[frame.depth > 0] for frame in sequence.frames(max_frames=frames, stride=stride)]
    return float(np.median(np.concatenate(depth)))


def odometry_errors(
    sequence: RgbdSequence, configuration: dict[str, float], seed: int, frames: int
) -> tuple[int, float, float]:
    """Frames with an odometry pose, the odometry's RPE over one frame (mm, RMSE) and its ATE
    (cm, RMSE) over the first ``frames`` frames of ``sequence`` (which has a groundtruth)."""
    assert sequence.groundtruth is not None  # opened by with_groundtruth
    spec = lab.pipeline_spec("rtabmap", preset=configuration, seed=seed)
    odometry = lab.run(sequence, spec, "rtabmap", max_frames=frames).run.odometry
    assert odometry is not None  # rtabmap keeps its odometry poses
    scored = evaluate(sequence.groundtruth, odometry, delta=1, delta_unit=DeltaUnit.FRAMES)
    return len(odometry), 1000 * lab.rmse(scored.rpe_trans), 100 * lab.rmse(scored.ate)


def measure(sequences: dict[str, RgbdSequence], frames: int, seeds: int) -> list[dict]:
    """One row per sequence (by label): its median depth, and per configuration the frames
    tracked and the errors over the seeds."""
    rows = []
    for label, sequence in sequences.items():
        row: dict = {"folder": label, "depth": median_depth(sequence, frames), "runs": {}}
        for name, configuration in CONFIGURATIONS.items():
            row["runs"][name] = [odometry_errors(sequence, configuration, seed, frames) for seed in range(seeds)]
        rows.append(row)
    return rows


def table(rows: list[dict]) -> str:
    names = list(CONFIGURATIONS)
    lines = [
        "| Frames | median depth [m] | " + " | ".join(f"{name}: RPE 1 frame [mm] / ATE [cm]" for name in names) + " |",
        "|---|---:|" + "---|" * len(names),
    ]
    for row in rows:
        cells = []
        for name in names:
            runs = row["runs"][name]
            tracked = statistics.median(run[0] for run in runs)
            cells.append(
                f"{spread([run[1] for run in runs], 1)} / {spread([run[2] for run in runs])} ({tracked:.0f} frames)"
            )
        lines.append(f"| {row['folder']} | {row['depth']:.2f} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    arguments = lab.arguments(argv)
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.odometry_adjustment", description=__doc__.splitlines()[0]
    )
    parser.add_argument("folders", nargs="*", type=Path, help="TUM folders with groundtruth")
    parser.add_argument(
        "--render",
        action="append",
        default=[],
        metavar="SCENE:SEED",
        help="a synthetic scene at its own length, 640x480, as benchmarks.oracle renders it",
    )
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("recordings/oracle"),
        help="where --render keeps its frames (benchmarks.oracle's --out)",
    )
    parser.add_argument("--frames", type=int, default=50, help="the first frames of each folder (default 50)")
    parser.add_argument("--seeds", type=int, default=4, help="pipeline seeds 0..N-1 (default 4)")
    parser.add_argument("--docs", action="store_true", help="write the table into docs/pipelines/rtabmap.md")
    options = parser.parse_args(arguments)
    if options.frames < 2 or options.seeds < 1:
        raise InputError("--frames must be at least 2 and --seeds at least 1")
    folders = {folder.name: with_groundtruth(folder) for folder in options.folders}
    if not folders and not options.render:
        raise InputError("no frames: give a TUM folder or --render SCENE:SEED")
    rendered = {scene: with_groundtruth(_rendered(scene, options.out)) for scene in options.render}
    sequences = {**rendered, **folders}
    text = f"{stamp(invocation(parser.prog, arguments))}\n\n{table(measure(sequences, options.frames, options.seeds))}"
    if options.docs:
        write_block(DOCUMENT, BLOCK, text)
    print(text)
    return 0


def with_groundtruth(folder: Path) -> RgbdSequence:
    """The frames of ``folder``, refused without a groundtruth to measure against."""
    sequence = open_source(folder)
    if sequence.groundtruth is None:
        raise InputError(f"{folder}: no groundtruth.txt, so no error to measure")
    return sequence


def _rendered(scene: str, out: Path) -> Path:
    name, _, seed = scene.partition(":")
    if not seed.isdigit():
        raise InputError(f"--render {scene}: expected SCENE:SEED, for instance 360_kidnap:0")
    return render(name, int(seed), None, out / "frames")  # as benchmarks.oracle renders and keeps it


if __name__ == "__main__":
    lab.main_of(main)
