"""`viewslam evaluate`: score trajectory files against groundtruth, one table row per estimate."""

from pathlib import Path
from typing import cast

import typer

from ..errors import InputError
from ..evaluation.alignment import Alignment
from ..evaluation.coverage import Span
from ..evaluation.evaluation import RpeMode
from ..evaluation.rpe import DeltaUnit
from ..geometry.trajectory_formats import TrajectoryFormat
from ..runs.evaluate_command import evaluate
from ..runs.evaluate_console import print_results
from ..runs.trajectory_files import ScoringOptions
from .app import app
from .options import finite, parse_span, positive


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
    max_difference: float = typer.Option(
        0.02, callback=positive, help="Largest time difference of an associated pair, in seconds."
    ),
    offset: float = typer.Option(
        0.0, callback=finite, help="Seconds added to the estimates' stamps before association."
    ),
    align: Alignment = typer.Option(
        Alignment.RIGID,
        help="Alignment of ATE and penalised ATE: rigid (Horn), sim3 "
        "(with scale), origin (first poses), segments (each "
        "tracked segment on its own) or none.",
    ),
    scale: bool = typer.Option(False, "--scale", help="The same as --align sim3 (monocular estimates)."),
    delta: float = typer.Option(1.0, callback=positive, help="RPE distance between poses."),
    delta_unit: DeltaUnit = typer.Option(DeltaUnit.SECONDS, help="Unit of --delta."),
    all_deltas: bool = typer.Option(False, "--all-deltas", help="RPE averaged over all distances (sampled)."),
    rpe_mode: RpeMode = typer.Option(
        RpeMode.DELTA,
        "--rpe-mode",
        help="RPE pairs: delta (--delta/--delta-unit, or --all-deltas) or tum (TUM "
        "evaluate_rpe.py's default as published figures ran it: all pose pairs "
        "under 100 poses, else 10,000 pairs drawn by Python 2.7's random seeded 0).",
    ),
    span: str | None = typer.Option(
        None,
        "--span",
        metavar="START,END",
        callback=parse_span,
        help="Coverage span in groundtruth seconds (default: a sequence's frames, "
        "else from the estimate's first pose to the groundtruth's last).",
    ),
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
    if delta_unit is DeltaUnit.FRAMES:
        from ..pipelines.params import INT_MAX  # parameters' pydantic only when it matters

        if not (delta == int(delta) and delta <= INT_MAX):
            raise typer.BadParameter(
                f"a delta in frames must be a whole number up to {INT_MAX}, got {delta}", param_hint="--delta"
            )
    if scale and align not in (Alignment.RIGID, Alignment.SIM3):
        raise InputError(f"--scale means --align sim3 and cannot be combined with --align {align}")
    options = ScoringOptions(
        max_difference,
        offset,
        Alignment.SIM3 if scale else align,
        delta,
        delta_unit,
        all_deltas,
        rpe_mode,
        cast(Span | None, span),
    )  # --span's callback made it a Span
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
