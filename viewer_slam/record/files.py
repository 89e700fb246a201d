"""`viewslam record --groundtruth FILE --estimate NAME=FILE ...`: trajectory files alone, scored as
``viewslam evaluate`` scores them (:mod:`viewer_slam.runs.trajectory_files`) and recorded as
:mod:`viewer_slam.rerun_adapter.files_only` lays them out, the report and trajectories beside
the recording as ``record`` writes them.
"""

from functools import partial
from pathlib import Path

from ..atomic import StagedFiles, exclusive
from ..errors import InputError
from ..geometry.trajectory import write_tum
from ..geometry.trajectory_formats import TrajectoryFormat
from ..rerun_adapter.blueprint import files_blueprint
from ..rerun_adapter.files_only import log_files
from ..rerun_adapter.rrd_file import RecordingFile
from ..rerun_adapter.viewer import LiveViewer
from ..runs.run_report import write_report
from ..runs.run_specs import say_estimate_format
from ..runs.trajectory_files import read_groundtruth, score_files
from .options import RecordResult
from .outputs import check_outputs, earlier_trajectories, report_paths

FILES_ONLY = "a recording of trajectory files alone (--groundtruth without SEQUENCE)"


def record_trajectory_files(
    groundtruth: Path,
    estimates: list[tuple[str, Path]],
    out: Path,
    *,
    format: TrajectoryFormat | None = None,
    name: str | None = None,
    viewer: LiveViewer | None = None,
    quiet: bool = True,
) -> RecordResult:
    """Record the ``(name, file)`` estimates against the groundtruth file into ``out`` (.rrd), the
    report and trajectories beside it (module docstring).

    ``format`` is every estimate's (default: detected; unless ``quiet``, stderr says which was
    read); ``name`` names the groundtruth in the report and summary (default: its file name
    without extension); ``viewer`` is also shown the recording live. Outputs are checked before anything is read, never replace an input,
    and are written under temporary names renamed into place together at the end.
    """
    names = [run for run, _ in estimates]
    inputs = {
        Path(groundtruth): f"--groundtruth {groundtruth}",
        **{Path(file): f"--estimate {run}={file}" for run, file in estimates},
    }
    check_outputs(out, names, inputs)
    with exclusive([out]):
        if Path(groundtruth).is_dir():
            raise InputError.at(
                groundtruth, "is a folder; --groundtruth takes a trajectory file (a sequence folder is SEQUENCE)"
            )
        scored = score_files(read_groundtruth(groundtruth), estimates, format, name=name)
        if not quiet:
            for run in scored.runs:
                say_estimate_format(run.name, run.path, run.format, given=bool(format))
        report = scored.report()
        report_path, trajectory_paths = report_paths(out, names)
        earlier = earlier_trajectories(out)
        error_top = max(float(run.ate.errors.max()) for run in scored.runs)
        with StagedFiles() as staged:
            recording = RecordingFile(
                staged.path(out), out, files_blueprint(names, scored.groundtruth.poses, error_top), viewer
            )
            try:
                log_files(recording.stream, scored, error_top)
            finally:
                recording.close()
            if recording.error is not None:
                raise InputError(f"{out}: recording not written: {recording.error}")
            for run in scored.runs:
                staged.write(trajectory_paths[run.name], partial(write_tum, trajectory=run.trajectory))
            staged.write(report_path, lambda path: write_report(path, report))
            staged.commit()
    for path in set(earlier) - set(trajectory_paths.values()):
        path.unlink(missing_ok=True)  # the earlier recording's, which the report now in place does not list
    return RecordResult(out, report_path, trajectory_paths, report, [out, report_path, *trajectory_paths.values()])
