"""`viewslam record`."""

from pathlib import Path

import typer

from .app import app
from .exits import EXIT_INTERRUPTED
from .options import MAX_FRAMES_HELP
from .run_options import Config, Estimates, Format, Params, Pipelines, Seed


@app.command("record")
def record_command(
    sequence: str | None = typer.Argument(
        None,
        help="TUM folder, ROS bag (FILE.bag or a ROS 2 bag folder), synthetic scenario or TUM sequence "
        "name; none: the built-in demo.",
    ),
    pipeline: Pipelines = None,
    estimate: Estimates = None,
    format: Format = None,
    out: Path | None = typer.Option(
        None, help="Recording to write (default recordings/<sequence>.rrd); NAME.json and NAME.<run>.txt go beside it."
    ),
    max_frames: int | None = typer.Option(None, min=1, help=MAX_FRAMES_HELP),
    stride: int = typer.Option(1, min=1, help="Use every K-th frame."),
    param: Params = None,
    config: Config = None,
    seed: Seed = 0,
    quiet: bool = typer.Option(False, "--quiet", help="No progress bar and no summary."),
    spawn: bool = typer.Option(False, "--spawn", help="Also stream live into a Rerun viewer started for this run."),
    connect: str | None = typer.Option(
        None,
        metavar="ADDR",
        help="Also stream live into the Rerun viewer already "
        "running at ADDR (HOST:PORT or rerun+http://HOST:PORT/proxy).",
    ),
    rgb_topic: str | None = typer.Option(None, help="ROS bag: the colour image topic (default: found by type)."),
    depth_topic: str | None = typer.Option(None, help="ROS bag: the depth image topic (default: found by type)."),
    camera_info_topic: str | None = typer.Option(
        None, help="ROS bag: the camera info topic (default: the one beside the colour topic)."
    ),
    groundtruth: Path | None = typer.Option(
        None,
        help="Groundtruth trajectory file (TUM, EuRoC). Without "
        "SEQUENCE: record the --estimate files alone against it, "
        "scored as `evaluate` does (no images, no pipeline). With a "
        "ROS bag: its groundtruth instead of the bag's /tf.",
    ),
    groundtruth_topic: str | None = typer.Option(None, help="ROS bag: groundtruth pose topic instead of /tf."),
) -> int:
    """Run SLAM pipelines over SEQUENCE (a TUM folder, scenario, TUM name or ROS bag) into a Rerun
    recording, with a report and trajectories; --estimate adds other systems' trajectories as runs.
    --groundtruth FILE with no SEQUENCE records the --estimate files alone against it."""
    from ..record.command import record
    from ..record.console import print_summary
    from ..record.inputs import BagTopics

    result = record(
        sequence,
        pipeline=pipeline or None,
        estimates=estimate or (),
        format=format,
        out=out,
        max_frames=max_frames,
        stride=stride,
        params=param or (),
        config=config,
        seed=seed,
        quiet=quiet,
        spawn=spawn,
        connect=connect,
        groundtruth=groundtruth,
        bag=BagTopics(rgb_topic, depth_topic, camera_info_topic, groundtruth_topic),
    )
    if not quiet:
        print_summary(result.report, result.written)
    return EXIT_INTERRUPTED if result.interrupted else 0
