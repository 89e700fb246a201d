"""`viewslam evaluate`: score trajectory files against groundtruth, one table row per estimate."""

from pathlib import Path

import typer

from ..evaluation.alignment import Alignment
from ..evaluation.evaluation import RpeMode
from ..evaluation.rpe import DeltaUnit
from ..geometry.trajectory_formats import TrajectoryFormat
from ..runs.evaluate_command import evaluate
from ..runs.evaluate_console import print_results
from . import scoring_options as scoring
from .app import app


@app.command("evaluate")
def evaluate_command(
    groundtruth: Path = typer.Argument(
        ...,
        help="Groundtruth trajectory (TUM or EuRoC), a TUM sequence folder or a ROS bag (.bag file or ROS 2 folder).",
    ),
    estimates: list[Path] = typer.Argument(
        ...,
        help="Estimated trajectories (TUM, KITTI, EuRoC, an rtabmap.db, or a ROS bag's "
        "pose topic); one table row each.",
    ),
    json_path: Path | None = typer.Option(None, "--json", help="Write the metric blocks as JSON."),
    plot: Path | None = typer.Option(
        None, "--plot", help="Write a picture (.png, .pdf, .svg, ...): aligned top view and errors over time."
    ),
    max_difference: scoring.MaxDifference = 0.02,
    offset: scoring.Offset = 0.0,
    align: scoring.Align = Alignment.RIGID,
    scale: scoring.Scale = False,
    delta: scoring.Delta = 1.0,
    delta_unit: scoring.DeltaUnits = DeltaUnit.SECONDS,
    all_deltas: scoring.AllDeltas = False,
    rpe_mode: scoring.RpePairs = RpeMode.DELTA,
    span: scoring.CoverageSpan = None,
    sequence: Path | None = typer.Option(
        None,
        "--sequence",
        metavar="FOLDER",
        help="TUM sequence folder (or ROS bag) whose frames set the coverage span, the "
        "frame period and a KITTI file's times.",
    ),
    format: TrajectoryFormat | None = typer.Option(
        None, "--format", help="Format of the estimates (default: detected)."
    ),
    groundtruth_topic: str | None = typer.Option(
        None,
        "--groundtruth-topic",
        metavar="TOPIC",
        help="The bag's pose topic to score against (default: the tf "
        "chain to the colour camera, else the only pose topic).",
    ),
    estimate_topic: str | None = typer.Option(
        None,
        "--estimate-topic",
        metavar="TOPIC",
        help="The pose topic of estimates that are ROS bags (default: the bag's only pose topic).",
    ),
) -> None:
    """ATE (global and per segment), RPE, coverage and penalised ATE of each ESTIMATE against GROUNDTRUTH."""
    options = scoring.scoring_options(
        max_difference, offset, align, scale, delta, delta_unit, all_deltas, rpe_mode, span
    )
    result = evaluate(
        groundtruth,
        estimates,
        options=options,
        sequence=sequence,
        format=format,
        groundtruth_topic=groundtruth_topic,
        estimate_topic=estimate_topic,
        json=json_path,
        plot=plot,
    )
    print_results(result)
    for target in result.written:
        typer.echo(f"wrote {target}", err=True)
