"""`viewslam study`: the seed study replayed from its author's own runs, published beside reproduced."""

import sys
from pathlib import Path

import typer

from .app import app
from .options import QUIET_HELP


@app.command()
def study(
    sequences: list[str] = typer.Argument(
        None, help="Study sequences to replay (TUM name, fr2/360_kidnap or the author's folder); default: all seven."
    ),
    out: Path = typer.Option(Path("study-results"), help="Folder for results.json, report.md and the charts."),
    mirror: str = typer.Option(
        None,
        help="Base URL holding the author's repository's files (default: "
        "$VIEWSLAM_STUDY_MIRROR, else raw.githubusercontent.com at the pinned "
        "commit).",
    ),
    record: bool = typer.Option(
        False,
        "--record",
        help="Also write OUT/<sequence>.rrd: both runs against the "
        "groundtruth, as `record --groundtruth` records trajectory "
        "files (with its report and trajectories beside it).",
    ),
    list_only: bool = typer.Option(False, "--list", help="List the study's sequences and which are cached."),
    quiet: bool = typer.Option(False, "--quiet", help=QUIET_HELP),
) -> None:
    """Fetch the study's runs (SHA-256 checked), score them as the study did and with coverage, and report."""
    from ..study.command import cached_sequences, study_sequences
    from ..study.command import study as run

    if list_only:
        study_sequences(sequences or ())  # a name the study does not know is refused all the same
        for sequence, cached in cached_sequences():
            typer.echo(f"{sequence.alias:<42} {sequence.folder:<36} {'cached' if cached else ''}".rstrip())
        return
    command = "viewslam study " + " ".join(sys.argv[2:]) if sys.argv[1:2] == ["study"] else "viewslam study"
    result = run(sequences or (), out=out, mirror=mirror, record=record, quiet=quiet, command=command)
    from ..study.study_outputs import table

    typer.echo(table(list(result.runs)))
    typer.echo(f"{len(result.discrepancies)} discrepancies between the published figures and the runs:")
    for entry in result.discrepancies:
        typer.echo(f"  {entry['text']}")
    for output in result.written:
        typer.echo(f"wrote {output}", err=True)
