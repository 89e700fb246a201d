"""`viewslam evaluate`: score trajectory files against groundtruth, one table row per estimate."""

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import cast

import numpy as np
import typer
from rich import box
from rich.markup import escape
from rich.table import Table

from ..atomic import StagedFiles, check_writable, refuse_inputs_as_outputs
from ..dataset.sources import open_source
from ..errors import InputError
from ..evaluation import Evaluation, evaluate
from ..evaluation.alignment import Alignment
from ..evaluation.coverage import Span
from ..evaluation.evaluation import RpeMode, why_no_pairs
from ..evaluation.rpe import DeltaUnit
from ..evaluation.statistics import stats_or_none
from ..geometry.trajectory import Trajectory, read_tum
from ..geometry.trajectory_formats import TrajectoryFormat, read_trajectory
from ..runs.report import write_report
from ..terminal import print_table
from .app import app

SEQUENCE_RULE = "sequence frames"
BAG_FORMAT = "bag"
FORMAT_NAMES = {TrajectoryFormat.TUM: "TUM", TrajectoryFormat.KITTI: "KITTI", TrajectoryFormat.EUROC: "EuRoC",
                TrajectoryFormat.RTABMAP: "an RTAB-Map database",
                BAG_FORMAT: "a ROS bag's pose topic"}
SPAN_OPTION_RULE = "--span"

GLOBAL_ALIGNMENT_TEXT = {
    Alignment.RIGID: "rigid alignment (Horn) over all pairs",
    Alignment.SIM3: "similarity alignment (Umeyama, with scale) over all pairs",
    Alignment.ORIGIN: "first poses laid onto each other (origin alignment)",
    Alignment.NONE: "no alignment",
    Alignment.SEGMENTS: "each tracked segment aligned rigidly on its own",
}
SEGMENT_ALIGNMENT_TEXT = {
    Alignment.RIGID: "each tracked segment aligned rigidly on its own",
    Alignment.SIM3: "each tracked segment aligned by a similarity on its own",
    Alignment.ORIGIN: "each tracked segment's first pose laid onto the groundtruth",
    Alignment.NONE: "no alignment",
    Alignment.SEGMENTS: "each tracked segment aligned rigidly on its own",
}


@dataclass
class Clock:
    """What a sequence tells about time: the coverage span, the frame period and the frame stamps
    (a KITTI file's times). None: unknown."""

    span: Span | None = None
    frame_period: float | None = None
    frame_stamps: np.ndarray | None = None


def _finite(value: float) -> float:
    if not math.isfinite(value):
        raise typer.BadParameter(f"must be a finite number, got {value}")
    return value


def _positive(value: float) -> float:
    if not (math.isfinite(value) and value > 0):
        raise typer.BadParameter(f"must be a finite positive number, got {value}")
    return value


def parse_span(text: str | None) -> Span | None:
    """``START,END`` in groundtruth seconds, START before END."""
    if text is None:
        return None
    try:
        start, end = (float(field) for field in text.split(","))
    except ValueError:
        raise typer.BadParameter(f"expected START,END in seconds, got {text!r}") from None
    if not (math.isfinite(start) and math.isfinite(end) and start < end):
        raise typer.BadParameter(f"expected two finite stamps with START < END, got {text!r}")
    return Span(start, end, SPAN_OPTION_RULE)


@app.command("evaluate")
def evaluate_command(
    groundtruth: Path = typer.Argument(..., help="Groundtruth trajectory (TUM format), a TUM sequence folder or a "
                                                 "ROS bag (.bag file or ROS 2 folder)."),
    estimates: list[Path] = typer.Argument(..., help="Estimated trajectories (TUM, KITTI, EuRoC, an rtabmap.db, or a ROS bag's "
                                                     "pose topic); one table row each."),
    json_path: Path | None = typer.Option(None, "--json", help="Write the metric blocks as JSON."),
    plot: Path | None = typer.Option(None, "--plot", help="Write a picture (.png, .pdf, .svg, ...): aligned top "
                                                          "view and errors over time."),
    max_difference: float = typer.Option(0.02, callback=_positive,
                                         help="Largest time difference of an associated pair, in seconds."),
    offset: float = typer.Option(0.0, callback=_finite,
                                 help="Seconds added to the estimates' stamps before association."),
    align: Alignment = typer.Option(Alignment.RIGID, help="Alignment of ATE and penalised ATE: rigid (Horn), sim3 "
                                                          "(with scale), origin (first poses), segments (each "
                                                          "tracked segment on its own) or none."),
    scale: bool = typer.Option(False, "--scale", help="The same as --align sim3 (monocular estimates)."),
    delta: float = typer.Option(1.0, callback=_positive, help="RPE distance between poses."),
    delta_unit: DeltaUnit = typer.Option(DeltaUnit.SECONDS, help="Unit of --delta."),
    all_deltas: bool = typer.Option(False, "--all-deltas", help="RPE averaged over all distances (sampled)."),
    rpe_mode: RpeMode = typer.Option(RpeMode.DELTA, "--rpe-mode",
                                     help="RPE pairs: delta (--delta/--delta-unit, or --all-deltas) or tum (TUM "
                                          "evaluate_rpe.py's default as published figures ran it: all pose pairs "
                                          "under 100 poses, else 10,000 pairs drawn by Python 2.7's random seeded 0)."),
    span: str | None = typer.Option(None, "--span", metavar="START,END", callback=parse_span,
                                    help="Coverage span in groundtruth seconds (default: a sequence's frames, "
                                         "else from the estimate's first pose to the groundtruth's last)."),
    sequence: Path | None = typer.Option(None, "--sequence", metavar="FOLDER",
                                         help="TUM sequence folder (or ROS bag) whose frames set the coverage span, the "
                                              "frame period and a KITTI file's times."),
    format: TrajectoryFormat | None = typer.Option(None, "--format", help="Format of the estimates (default: detected)."),
    groundtruth_topic: str | None = typer.Option(None, "--groundtruth-topic", metavar="TOPIC",
                                                 help="The bag's pose topic to score against (default: the tf "
                                                      "chain to the colour camera, else the only pose topic)."),
    estimate_topic: str | None = typer.Option(None, "--estimate-topic", metavar="TOPIC",
                                              help="The pose topic of estimates that are ROS bags (default: the "
                                                   "bag's only pose topic)."),
) -> None:
    """ATE (global and per segment), RPE, coverage and penalised ATE of each ESTIMATE against GROUNDTRUTH."""
    if delta_unit is DeltaUnit.FRAMES:
        from ..pipelines.params import INT_MAX  # parameters' pydantic only when it matters

        if not (delta == int(delta) and delta <= INT_MAX):
            raise typer.BadParameter(f"a delta in frames must be a whole number up to {INT_MAX}, got {delta}",
                                     param_hint="--delta")
    if rpe_mode is RpeMode.TUM and (all_deltas or delta != 1.0 or delta_unit is not DeltaUnit.SECONDS):
        raise InputError("--rpe-mode tum draws its own pose pairs and cannot be combined with --delta, "
                         "--delta-unit or --all-deltas")
    if scale and align not in (Alignment.RIGID, Alignment.SIM3):
        raise InputError(f"--scale means --align sim3 and cannot be combined with --align {align}")
    if plot is not None:
        from ..evaluation.plot import check_plot_path  # matplotlib only when a plot is wanted

        check_plot_path(plot)
    outputs = {path: option for path, option in ((json_path, "--json"), (plot, "--plot")) if path is not None}
    refuse_inputs_as_outputs(outputs, {path: f"{what} {path}" for path, what in ((groundtruth, "GROUNDTRUTH"),
                             *((estimate, "ESTIMATE") for estimate in estimates), (sequence, "--sequence"))
                             if path is not None})
    for output in outputs:
        check_writable(output)
    reference, clock = _groundtruth_and_clock(groundtruth, groundtruth_topic)
    if sequence is not None:
        clock = _sequence_clock(sequence)
    labels = [str(path) for path in estimates]
    repeated = next((path for path, label in zip(estimates, labels) if labels.count(label) > 1), None)
    if repeated is not None:
        raise InputError.at(repeated, "given twice as an estimate")
    estimated, formats = zip(*(_read_estimate(path, format, clock, estimate_topic) for path in estimates))
    coverage_span = cast(Span | None, span) or clock.span  # --span's callback (parse_span) made it a Span
    evaluations = []
    for path, trajectory in zip(estimates, estimated):
        evaluation = evaluate(reference, trajectory, max_difference=max_difference, offset=offset,
                              align=Alignment.SIM3 if scale else align, delta=delta, delta_unit=delta_unit,
                              all_deltas=all_deltas, span=coverage_span, frame_period=clock.frame_period,
                              rpe_mode=rpe_mode)
        if evaluation.ate is None:
            raise InputError.at(path, why_no_pairs(reference, trajectory, offset, max_difference))
        evaluations.append(evaluation)

    _print_results(groundtruth, labels, formats, evaluations)
    writers = {}
    if json_path is not None:
        blocks = {label: evaluation.to_dict() for label, evaluation in zip(labels, evaluations)}
        report = blocks[labels[0]] if len(labels) == 1 else {"groundtruth": str(groundtruth), "estimates": blocks}
        writers[json_path] = lambda path: write_report(path, report)
    if plot is not None:
        from ..evaluation.plot import Scored, plot_evaluation

        scored = [Scored(Path(label).name, trajectory, evaluation)
                  for label, trajectory, evaluation in zip(labels, estimated, evaluations)]
        writers[plot] = lambda path: plot_evaluation(path, reference, scored, format=plot.suffix.lstrip(".").lower())
    _write_together(writers)


def _write_together(writers: dict[Path, Callable[[Path], None]]) -> None:
    """Each target written by its writer under a temporary name beside it, then all renamed into
    place together: a failure to write one (a full disk) is a one-line input error naming it, and
    leaves every target as it was. Says on stderr what was written."""
    with StagedFiles() as staged:
        for target, write in writers.items():
            try:
                write(staged.path(target))
            except OSError as error:
                raise InputError.at(target, f"cannot write: {error.strerror or error}") from None
        staged.commit()
    for target in writers:
        typer.echo(f"wrote {target}", err=True)


def _groundtruth_and_clock(path: Path, topic: str | None = None) -> tuple[Trajectory, Clock]:
    """A trajectory file (no clock), or a sequence folder's or bag's groundtruth and its frames' clock
    (a bag of poses alone has none); ``topic`` names a bag's pose topic."""
    from ..dataset.rosbag import is_bag  # the bag reader itself loads only for a bag

    if is_bag(path):
        from ..dataset.rosbag import open_groundtruth

        reference, sequence = open_groundtruth(path, groundtruth_topic=topic)
        return reference, _clock_of(sequence) if sequence is not None else Clock()
    if topic is not None:
        raise InputError(f"--groundtruth-topic: only for a ROS bag, and {path} is not one")
    if not path.is_dir():
        return read_tum(path), Clock()
    folder = open_source(path)
    if folder.groundtruth is None:
        raise InputError.at(path, "sequence has no groundtruth.txt")
    return folder.groundtruth, _clock_of(folder)


def _read_estimate(path: Path, format: TrajectoryFormat | None, clock: Clock,
                   topic: str | None) -> tuple[Trajectory, str]:
    """An estimate and the format it was read as: a bag's pose topic, else a file in ``format`` or a detected one."""
    from ..dataset.rosbag import bag_poses, is_bag

    if is_bag(path):
        return bag_poses(path, topic, option="--estimate-topic"), BAG_FORMAT
    return read_trajectory(path, format, clock.frame_stamps)


def _sequence_clock(path: Path) -> Clock:
    from ..dataset.rosbag import is_bag

    if not path.is_dir() and not is_bag(path):
        raise InputError(f"--sequence {path}: not a folder or a ROS bag")
    return _clock_of(open_source(path))


def _clock_of(sequence) -> Clock:
    """Coverage over the time the camera recorded, in units of its frame period."""
    stamps = np.asarray(sequence.timestamps, dtype=np.float64)
    return Clock(Span(float(stamps[0]), float(stamps[-1]), SEQUENCE_RULE), sequence.frame_period, stamps)


def plural(count: float, noun: str) -> str:
    return f"{count} {noun}" if count == 1 else f"{count} {noun}s"


def _print_results(groundtruth: Path, labels: list[str], formats: Sequence[str], evaluations: list[Evaluation]) -> None:
    """The legend of the columns (which alignment each uses), the table, and for each estimate the
    format it was read as and its coverage span."""
    first = evaluations[0]
    if first.rpe_mode == RpeMode.TUM:
        from ..evaluation.tum_rpe import MODE_TEXT

        rpe_pairs = MODE_TEXT
    elif first.delta is None:
        rpe_pairs = "all Δ (sampled)"
    elif first.delta_unit == DeltaUnit.SECONDS:
        rpe_pairs = f"Δ = {first.delta:g} s"
    else:
        rpe_pairs = f"Δ = {plural(first.delta, 'frame')}"
    lines = [f"RMSE against {groundtruth}",
             f"  ATE, penal. ATE [m]: {GLOBAL_ALIGNMENT_TEXT[first.alignment_name]}",
             f"  ATE seg. [m]: {SEGMENT_ALIGNMENT_TEXT[first.alignment_name]}",
             f"  RPE trans [m], rot [deg]: alignment-free, {rpe_pairs}"]
    table = Table(box=box.SIMPLE_HEAD, pad_edge=False, show_edge=False)
    for column in ("estimate", "pairs", "coverage", "ATE", "ATE seg.", "RPE trans", "RPE rot", "penal. ATE"):
        table.add_column(column, justify="left" if column == "estimate" else "right", no_wrap=True)
    for label, evaluation in zip(labels, evaluations):
        table.add_row(escape(label), *_row(evaluation))
    typer.echo("\n".join(lines))
    print_table(table)
    typer.echo("\n".join(f"{label}: read as {FORMAT_NAMES[name]}; {_coverage_text(evaluation)}"
                          for label, name, evaluation in zip(labels, formats, evaluations)))


def _row(evaluation: Evaluation) -> list[str]:
    def rmse(series) -> str:
        stats = stats_or_none(series)
        return "—" if stats is None else f"{stats['rmse']:.4f}"

    return [str(len(evaluation.pairs[0])), f"{evaluation.coverage.ratio:.1%}", rmse(evaluation.ate),
            rmse(evaluation.segment_ate), rmse(evaluation.rpe_trans), rmse(evaluation.rpe_rot),
            rmse(evaluation.penalized_ate)]


def _coverage_text(evaluation: Evaluation) -> str:
    span = evaluation.coverage.span
    lost = len(evaluation.coverage.lost_intervals)
    return (f"coverage over {span.start:.6f}..{span.end:.6f} ({span.end - span.start:.3f} s, {span.rule}), "
            f"{plural(lost, 'lost interval')}")
