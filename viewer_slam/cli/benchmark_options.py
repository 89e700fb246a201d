"""The options of `viewslam benchmark` that are its own: what it runs over, how its tasks are
executed, and what it writes."""

from pathlib import Path
from typing import Annotated

import typer

from .options import MAX_FRAMES_HELP

MAX_TIMEOUT_S = 7 * 24 * 3600  # a week: beyond it a task's deadline is no deadline (and inf none at all)

Sequences = Annotated[
    list[str] | None,
    typer.Argument(
        help="TUM folders, TUM sequence names (fr2/360_kidnap) or synthetic scenarios; default: the seven "
        "synthetic scenarios.",
        show_default=False,
    ),
]
OldPipelines = Annotated[list[str] | None, typer.Option("--pipelines", hidden=True)]  # the old spelling
MaxFrames = Annotated[int | None, typer.Option("--max-frames", min=2, help=MAX_FRAMES_HELP)]
ScenarioFrames = Annotated[
    int | None,
    typer.Option(
        min=2, help="Length synthetic scenarios are rendered at, as `viewslam synth --frames` (default: their own)."
    ),
]
Resolution = Annotated[str, typer.Option(help="Synthetic scenarios' image size, WIDTHxHEIGHT.")]
Jobs = Annotated[int | None, typer.Option(min=1, help="Tasks run at once (default: the number of cores).")]
Executor = Annotated[str, typer.Option(help="local (process pool) or ray.")]
RayAddress = Annotated[str | None, typer.Option(help="Address of an existing Ray cluster (default: start one).")]
Out = Annotated[Path, typer.Option(help="Folder for results, report and charts.")]
RecordEach = Annotated[bool, typer.Option(help="Also write a Rerun recording per task into OUT/recordings.")]
Trials = Annotated[
    int,
    typer.Option(
        min=1,
        help="Runs of every pipeline per sequence, trial k with seed SEED + k; tables and charts give the median "
        "and min–max.",
    ),
]
Timeout = Annotated[
    float | None,
    typer.Option(min=1, max=MAX_TIMEOUT_S, help="Seconds after which a task is stopped and reported failed."),
]
Cache = Annotated[bool, typer.Option(help="Reuse results of unchanged tasks from earlier runs.")]
Compare = Annotated[
    Path | None,
    typer.Option(
        "--compare",
        metavar="OTHER_RESULTS_DIR",
        help="Also compare every row with the same row of an earlier benchmark's --out (in report.md), as "
        "`viewslam diff` does.",
    ),
]
