"""``viewslam diff`` as a library function: two recorded runs of one sequence compared frame by
frame (:mod:`viewer_slam.comparison`), the comparison written as JSON and as a Rerun recording."""

from dataclasses import dataclass
from pathlib import Path

from ..atomic import StagedFiles, check_writable, refuse_inputs_as_outputs
from ..comparison import Comparison, compare_reports, comparison_to_dict
from ..errors import InputError
from ..runs.run_report import write_report


@dataclass(frozen=True)
class DiffResult:
    """The comparison of every run pair (differences are B - A) and the files written."""

    comparison: Comparison
    written: tuple[Path, ...]


def diff(
    a: Path, b: Path, *, runs: tuple[str, str] | None = None, json: Path | None = None, out: Path | None = None
) -> DiffResult:
    """Compare the runs of report ``a`` with those of report ``b`` (``NAME.json`` of a record, the
    trajectories beside it; one sequence): errors, frames only one tracked, losses, parameters,
    scores. ``runs`` pairs run A_RUN of ``a`` with B_RUN of ``b`` (default: the runs of the same
    name). Writes the comparison as JSON to ``json`` and a recording of both runs and the
    difference to ``out`` (.rrd); both are checked before anything is read.
    """
    if out is not None and out.suffix != ".rrd":
        raise InputError.at(out, "the recording must have the .rrd extension")
    outputs = {path: option for path, option in ((out, "--out"), (json, "--json")) if path is not None}
    refuse_inputs_as_outputs(outputs, {a: f"A {a}", b: f"B {b}"})
    for target in outputs:
        check_writable(target)
    comparison = compare_reports(a, b, runs)
    if json is not None:
        data = comparison_to_dict(comparison)
        with StagedFiles() as staged:
            staged.write(json, lambda staged_path: write_report(staged_path, data))
            staged.commit()
    if out is not None:
        from ..rerun_adapter.diff_recording import write_diff_recording  # Rerun loads only for a recording

        write_diff_recording(comparison, out)
    return DiffResult(comparison, tuple(path for path in (json, out) if path is not None))
