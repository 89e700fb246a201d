"""`viewslam diff`: compare two recorded runs of one sequence."""

from pathlib import Path

import typer

from ..errors import InputError
from .app import app


@app.command("diff")
def diff_command(
    a: Path = typer.Argument(..., help="Report A (NAME.json of `viewslam record`, trajectories beside it)."),
    b: Path = typer.Argument(..., help="Report B, of the same sequence; differences are B - A."),
    out: Path | None = typer.Option(None, help="Also write a recording (.rrd) of both runs and the difference."),
    json_path: Path | None = typer.Option(None, "--json", help="Also write the comparison as JSON to FILE."),
    runs: str | None = typer.Option(
        None,
        "--runs",
        metavar="A_RUN:B_RUN",
        help="Compare run A_RUN of A with run B_RUN of B (e.g. rgbdslam:rtabmap, "
        "also within one report); default: the runs of the same name.",
    ),
) -> int:
    """Compare two runs frame by frame: errors, frames only one tracked, losses, parameters, scores."""
    pair = _run_pair(runs)
    from ..comparison import print_comparison  # OpenCV loads only now
    from ..record.diff import diff

    result = diff(a, b, runs=pair, json=json_path, out=out)
    print_comparison(result.comparison)
    for target in result.written:
        print(f"wrote {target}")
    return 0


def _run_pair(runs: str | None) -> tuple[str, str] | None:
    if runs is None:
        return None
    name_a, colon, name_b = runs.partition(":")
    if not colon or not name_a or not name_b:
        raise InputError(f"--runs: expected A_RUN:B_RUN (e.g. rgbdslam:rtabmap), got {runs!r}")
    return name_a, name_b
