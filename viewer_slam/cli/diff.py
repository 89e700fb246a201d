"""`viewslam diff`: compare two recorded runs of one sequence."""

from pathlib import Path

import typer

from ..atomic import StagedFiles, check_writable, refuse_inputs_as_outputs
from ..errors import InputError
from ..runs.report import write_report
from .app import app


@app.command("diff")
def diff_command(
    a: Path = typer.Argument(..., help="Report A (NAME.json of `viewslam record`, trajectories beside it)."),
    b: Path = typer.Argument(..., help="Report B, of the same sequence; differences are B - A."),
    out: Path | None = typer.Option(None, help="Also write a recording (.rrd) of both runs and the difference."),
    json_path: Path | None = typer.Option(None, "--json", help="Also write the comparison as JSON to FILE."),
    runs: str | None = typer.Option(None, "--runs", metavar="A_RUN:B_RUN",
                                    help="Compare run A_RUN of A with run B_RUN of B (e.g. rgbdslam:rtabmap, "
                                         "also within one report); default: the runs of the same name."),
) -> int:
    """Compare two runs frame by frame: errors, frames only one tracked, losses, parameters, scores."""
    pair = _run_pair(runs)
    if out is not None and out.suffix != ".rrd":
        raise InputError.at(out, "the recording must have the .rrd extension")
    outputs = {path: option for path, option in ((out, "--out"), (json_path, "--json")) if path is not None}
    refuse_inputs_as_outputs(outputs, {a: f"A {a}", b: f"B {b}"})
    for target in outputs:
        check_writable(target)
    from ..comparison import compare_reports, comparison_to_dict, print_comparison  # OpenCV loads only now

    comparison = compare_reports(a, b, pair)
    print_comparison(comparison)
    if json_path is not None:
        _write_json(json_path, comparison_to_dict(comparison))
    if out is not None:
        from ..recording.diff_recording import write_diff_recording  # Rerun loads only for a recording

        write_diff_recording(comparison, out)
        print(f"wrote {out}")
    return 0


def _run_pair(runs: str | None) -> tuple[str, str] | None:
    if runs is None:
        return None
    name_a, colon, name_b = runs.partition(":")
    if not colon or not name_a or not name_b:
        raise InputError(f"--runs: expected A_RUN:B_RUN (e.g. rgbdslam:rtabmap), got {runs!r}")
    return name_a, name_b


def _write_json(path: Path, data: dict) -> None:
    with StagedFiles() as staged:
        staged.write(path, lambda staged_path: write_report(staged_path, data))
        staged.commit()
    print(f"wrote {path}")
