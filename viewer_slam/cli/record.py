"""`viewslam record`."""

from pathlib import Path

import typer

from ..geometry.trajectory_formats import TrajectoryFormat
from ..seeds import SEED_MAX
from .app import app
from .exits import EXIT_INTERRUPTED
from .options import MAX_FRAMES_HELP, PIPELINE_HELP

ESTIMATE_HELP = (
    "Another system's trajectory replayed as a run called NAME, e.g. orbslam3=CameraTrajectory.txt "
    "(TUM, KITTI poses on the sequence's frame stamps, EuRoC CSV, or an RTAB-Map database, whose maps, "
    "loop closures and statistics come along); repeatable. With estimates, "
    "no built-in pipeline runs unless --pipeline names some."
)


@app.command("record")
def record_command(
    sequence: str | None = typer.Argument(
        None,
        help="TUM folder, ROS bag (FILE.bag or a ROS 2 bag folder), synthetic scenario or TUM sequence "
        "name; none: the built-in demo.",
    ),
    pipeline: list[str] = typer.Option(
        [], help=PIPELINE_HELP + " Default: both, or none beside --estimate.", show_default=False
    ),
    estimate: list[str] = typer.Option([], metavar="NAME=FILE", help=ESTIMATE_HELP),
    format: TrajectoryFormat | None = typer.Option(
        None, help="Format of every --estimate file (default: detected; stderr says which was used)."
    ),
    out: Path | None = typer.Option(
        None, help="Recording to write (default recordings/<sequence>.rrd); NAME.json and NAME.<run>.txt go beside it."
    ),
    max_frames: int | None = typer.Option(None, min=1, help=MAX_FRAMES_HELP),
    stride: int = typer.Option(1, min=1, help="Use every K-th frame."),
    param: list[str] = typer.Option([], help="Pipeline parameter under its original name, KEY=VALUE."),
    config: Path | None = typer.Option(None, help="TOML file of parameters (flat, or one table per pipeline)."),
    seed: int = typer.Option(0, min=0, max=SEED_MAX, help="Seed of every random choice."),
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
        estimates=estimate,
        format=format,
        out=out,
        max_frames=max_frames,
        stride=stride,
        params=param,
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
