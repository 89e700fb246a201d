"""The options that say how trajectory files are scored (`viewslam evaluate`): association,
alignment, RPE pairs and the coverage span, each one `ScoringOptions` field."""

from typing import Annotated, cast

import typer

from ..errors import InputError
from ..evaluation.alignment import Alignment
from ..evaluation.coverage import Span
from ..evaluation.evaluation import RpeMode
from ..evaluation.rpe import DeltaUnit
from ..runs.trajectory_files import ScoringOptions
from .options import finite, parse_span, positive

MaxDifference = Annotated[
    float, typer.Option(callback=positive, help="Largest time difference of an associated pair, in seconds.")
]
Offset = Annotated[
    float, typer.Option(callback=finite, help="Seconds added to the estimates' stamps before association.")
]
Align = Annotated[
    Alignment,
    typer.Option(
        help="Alignment of ATE and penalised ATE: rigid (Horn), sim3 (with scale), origin (first poses), segments "
        "(each tracked segment on its own) or none."
    ),
]
Scale = Annotated[bool, typer.Option("--scale", help="The same as --align sim3 (monocular estimates).")]
Delta = Annotated[float, typer.Option(callback=positive, help="RPE distance between poses.")]
DeltaUnits = Annotated[DeltaUnit, typer.Option(help="Unit of --delta.")]
AllDeltas = Annotated[bool, typer.Option("--all-deltas", help="RPE averaged over all distances (sampled).")]
RpePairs = Annotated[
    RpeMode,
    typer.Option(
        "--rpe-mode",
        help="RPE pairs: delta (--delta/--delta-unit, or --all-deltas) or tum (TUM evaluate_rpe.py's default as "
        "published figures ran it: all pose pairs under 100 poses, else 10,000 pairs drawn by Python 2.7's random "
        "seeded 0).",
    ),
]
CoverageSpan = Annotated[
    str | None,
    typer.Option(
        "--span",
        metavar="START,END",
        callback=parse_span,
        help="Coverage span in groundtruth seconds (default: a sequence's frames, else from the estimate's first "
        "pose to the groundtruth's last).",
    ),
]


def scoring_options(
    max_difference: float,
    offset: float,
    align: Alignment,
    scale: bool,
    delta: float,
    delta_unit: DeltaUnit,
    all_deltas: bool,
    rpe_mode: RpeMode,
    span: str | None,
) -> ScoringOptions:
    """The options as one ``ScoringOptions``, after the checks no single option can make: a delta in
    frames is a whole number, and --scale (sim3) goes with no other alignment."""
    if delta_unit is DeltaUnit.FRAMES:
        from ..pipelines.params import INT_MAX  # parameters' pydantic only when it matters

        if not (delta == int(delta) and delta <= INT_MAX):
            raise typer.BadParameter(
                f"a delta in frames must be a whole number up to {INT_MAX}, got {delta}", param_hint="--delta"
            )
    if scale and align not in (Alignment.RIGID, Alignment.SIM3):
        raise InputError(f"--scale means --align sim3 and cannot be combined with --align {align}")
    span_ = cast(Span | None, span)  # --span's callback made it a Span
    return ScoringOptions(
        max_difference, offset, Alignment.SIM3 if scale else align, delta, delta_unit, all_deltas, rpe_mode, span_
    )
