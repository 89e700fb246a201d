"""`viewslam record`: run pipelines over a sequence into one Rerun recording, reports beside it.

A run is a pipeline (built-in or plugin) or an estimate (``--estimate NAME=FILE``, another
system's trajectory file replayed over the frames); every run gets the same recording
layout, report block and trajectory file. Estimates alone record no built-in pipeline
unless ``--pipeline`` asks for some.

Everything the user can get wrong (pipeline, parameters, output path, sequence) is checked
before the first frame is read. Pipelines run one after the other into the same
recording, sharing the ``frame`` and ``time`` timelines. Ctrl-C stops after the current
frame: the running pipeline finishes on the frames it saw, no further pipeline starts, and
the recording, report and trajectories are written as far as they got. A frame that turns
out unreadable mid-run (a corrupt PNG), or an unexpected error, ends the run the same way,
and its error is then raised: what came before it is kept. Every output is written under a
temporary name and renamed into place at the end, and a lock keeps two runs from writing
the same ``--out``. A recording the disk could not hold is removed (the previous one, if
any, stays) and the report says so.
"""

import contextlib
from collections.abc import Iterator
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

from .. import palette
from ..atomic import StagedFiles, exclusive
from ..dataset.frame import Frame, Sequence, TimedFrames, closing_frames, frames_read, select_frames
from ..diagnosis import MeasuredImages
from ..errors import InputError
from ..geometry.trajectory import write_tum
from ..pipelines.base import Pipeline
from ..pipelines.run import Sink
from ..rerun_adapter.background import RecordingThread
from ..rerun_adapter.blueprint import default_blueprint
from ..rerun_adapter.loss_causes import log_loss_causes
from ..rerun_adapter.recorder import PipelineRecorder, log_frame_image, log_world
from ..rerun_adapter.rrd_file import RecordingFile
from ..rerun_adapter.sizes import extent
from ..rerun_adapter.timelines import log_evaluation
from ..rerun_adapter.viewer import LiveViewer
from ..runs.replay import EstimateReplay
from ..runs.run_report import build_report, write_report
from ..runs.run_specs import say_estimate_format
from ..runs.service import EstimateSpec, RunSpec, ScoredRun, build_run, score_run
from ..stopping import SafePoints
from .console import RecordProgress
from .inputs import BagTopics, open_input
from .interrupt import StopRequest
from .options import FrameSelection, RecordResult
from .outputs import check_outputs, earlier_trajectories, report_paths


class GuardedSequence(TimedFrames):
    """A sequence whose first unreadable frame ends the frames there, as a stop request would.

    The error is kept in ``error``: the pipeline finishes on what it saw, and the caller saves
    it before failing. ``read`` counts the frames handed out.
    """

    def __init__(self, sequence: Sequence):
        self._sequence = sequence
        self.name, self.path = sequence.name, sequence.path
        self.camera, self.groundtruth = sequence.camera, sequence.groundtruth
        self.timestamps = sequence.timestamps
        self.error: InputError | None = None
        self.read = 0

    def frames(self, max_frames: int | None = None, stride: int = 1) -> Iterator[Frame]:
        try:
            with closing_frames(self._sequence.frames(max_frames=max_frames, stride=stride)) as frames:
                for frame in frames:
                    self.read += 1
                    yield frame
        except InputError as error:
            self.error = error


def record_runs(
    sequence: str | None,
    specs: dict[str, RunSpec],
    out: Path,
    *,
    frames: FrameSelection = FrameSelection(),
    quiet: bool = True,
    bag: BagTopics = BagTopics(),
    groundtruth: Path | None = None,
    config: Path | None = None,
    viewer: LiveViewer | None = None,
) -> RecordResult:
    """Record the runs ``specs`` over ``sequence`` (None: the demo; ``bag`` and ``groundtruth`` for a
    ROS bag) into ``out``, also shown live by ``viewer``.

    The outputs are checked before the sequence is opened (never replacing the estimate files,
    the ``config`` file the parameters came from, or the sequence), and every run is built (an
    estimate file read) before the first frame.
    """
    check_outputs(out, list(specs), _inputs(sequence, specs, config))
    with exclusive([out]):
        opened = open_input(
            sequence, bag, groundtruth, first=frames_read(frames.max_frames, frames.stride), progress=not quiet
        )
        runs = {
            name: build_run(spec, opened, max_frames=frames.max_frames, stride=frames.stride)
            for name, spec in specs.items()
        }
        if not quiet:
            _say_estimate_formats(specs, runs)
        return record_sequence(opened, runs, out, frames=frames, quiet=quiet, viewer=viewer)


def _inputs(sequence: str | None, specs: dict[str, RunSpec], config: Path | None) -> dict[Path, str]:
    """The files the record reads, which no output may replace (path -> how it was given)."""
    inputs = {
        Path(spec.file): f"--estimate {name}={spec.file}"
        for name, spec in specs.items()
        if isinstance(spec, EstimateSpec)
    }
    if config is not None:
        inputs[Path(config)] = f"--config {config}"
    if sequence is not None and Path(sequence).exists():
        inputs[Path(sequence)] = f"the sequence {sequence}"
    return inputs


def _say_estimate_formats(specs: dict[str, RunSpec], runs: dict[str, Pipeline]) -> None:
    """On stderr, the format each estimate file was read as, and whether it was given or detected."""
    for name, run in runs.items():
        spec = specs[name]
        if isinstance(run, EstimateReplay) and isinstance(spec, EstimateSpec):
            say_estimate_format(name, run.params.file, run.params.format, given=bool(spec.format))


@dataclass
class Recorded:
    """What the runs of a record gave: the scores of every run that ran (in order), whether one was
    cut short, and the failure that ended them early (None if none did)."""

    scored: dict[str, ScoredRun] = field(default_factory=dict)
    interrupted: bool = False
    failure: Exception | None = None


def record_sequence(
    sequence: Sequence,
    runs: dict[str, Pipeline],
    out: Path,
    *,
    frames: FrameSelection = FrameSelection(),
    quiet: bool = True,
    viewer: LiveViewer | None = None,
) -> RecordResult:
    """Record the ``runs`` (name -> pipeline or estimate replay), in order, over the ``frames`` of
    ``sequence`` into ``out`` (trusted: checked by the caller); ``viewer`` is also shown the
    recording live.

    Every file is written under a temporary name and renamed into place at the end (also
    after a stop request or a failure mid-run), so a run that fails before its first frame
    leaves the previous outputs as they were.
    """
    report_path, trajectory_paths = report_paths(out, list(runs))
    earlier = earlier_trajectories(out)
    with StagedFiles() as staged, StopRequest().installed() as stop:
        recording = RecordingFile(staged.path(out), out, _blueprint(sequence, runs), viewer)
        try:
            recorded = _record_runs(recording.stream, sequence, runs, frames, quiet, stop)
        finally:
            recording.close()
        if recording.error is not None:
            staged.discard(out)  # an incomplete file that readers refuse; the previous one stays
        errors = [
            str(recorded.failure) if recorded.failure is not None else None,
            f"{out}: {recording.error}" if recording.error is not None else None,
        ]
        report = _stage_results(staged, sequence, recorded, list(runs), trajectory_paths, report_path, errors)
        staged.commit()
    kept = {trajectory_paths[name] for name in recorded.scored}
    for path in set(earlier) - kept:
        path.unlink(missing_ok=True)  # the earlier run's, which the report now in place does not list
    written = [path for path in (out, report_path, *trajectory_paths.values()) if path.exists()]
    _raise_failure(out, report_path, recording.error, recorded.failure)
    return RecordResult(
        out, report_path, {name: trajectory_paths[name] for name in recorded.scored}, report, written, recorded.scored
    )


def _blueprint(sequence: Sequence, runs: dict[str, Pipeline]) -> Any:
    """The layout the recording opens with: every run's views, the groundtruth's path framing the 3D view."""
    groundtruth = sequence.groundtruth
    return default_blueprint(
        list(runs),
        None if groundtruth is None else groundtruth.poses,
        [name for name, run in runs.items() if _counts_features(run)],
    )


def _record_runs(
    stream: Any, sequence: Sequence, runs: dict[str, Pipeline], frames: FrameSelection, quiet: bool, stop: SafePoints
) -> Recorded:
    """Drive every run in turn into ``stream``, one recorder each, until all ran, a stop is requested
    or one fails; what came before a failure is kept."""
    recorded = Recorded()
    groundtruth = sequence.groundtruth
    scene_extent = None if groundtruth is None else extent(groundtruth.positions)
    total = len(select_frames(len(sequence), frames.max_frames, frames.stride))
    measured = MeasuredImages()  # every run goes over the same frames: each is measured once
    with RecordProgress(total, quiet=quiet) as progress, RecordingThread() as background:
        log_world(stream, groundtruth)
        for position, name in enumerate(runs):
            if stop.requested:
                break
            recorder = PipelineRecorder(
                stream,
                name,
                sequence.camera,
                palette.run_colour(name, position),
                scene_extent,
                tracker_counts=_counts_features(runs[name]),
            )
            guarded = GuardedSequence(sequence)
            try:
                scored = _record_run(
                    guarded,
                    runs[name],
                    name,
                    recorder,
                    background,
                    progress.sink(name),
                    images=stream if position == 0 else None,
                    image_signals=measured,
                    frames=frames,
                    stop=stop,
                )
            except (Exception, SystemExit) as error:  # an unexpected failure: keep what was recorded
                recorded.failure = _run_failure(name, error)
                if not recorded.scored and not guarded.read:  # nothing to keep
                    if recorded.failure is error:
                        raise
                    raise recorded.failure from error
                break
            recorded.failure = guarded.error
            if recorded.failure is not None and not scored.run.frames:
                raise recorded.failure  # not one frame was read: there is nothing to keep
            recorded.interrupted = recorded.interrupted or scored.run.interrupted or recorded.failure is not None
            _log_scores(stream, name, scored)
            recorded.scored[name] = scored
            if recorded.failure is not None:
                break
    return recorded


def _record_run(
    sequence: GuardedSequence,
    run: Pipeline,
    name: str,
    recorder: PipelineRecorder,
    background: RecordingThread,
    progress: Sink,
    *,
    images: Any,
    image_signals: MeasuredImages,
    frames: FrameSelection,
    stop: SafePoints,
) -> ScoredRun:
    """Drive one run over the frames with ``recorder`` as a sink on the recording thread, and score
    it once all its events are recorded; ``images`` is the stream that gets each frame's image (the
    first run's only: one copy serves every run's view); ``image_signals`` measures what each
    frame shows, once for all the runs."""

    def on_frame(frame: Frame) -> None:
        background.submit(recorder.begin_frame, frame)
        if images is not None:
            background.submit(log_frame_image, images, frame)

    try:
        scored = score_run(
            sequence,
            run,
            name,
            max_frames=frames.max_frames,
            stride=frames.stride,
            sinks=[background.sink(recorder), progress],
            frame_sinks=[on_frame],
            should_stop=stop,
            image_signals=image_signals,
        )
    except BaseException:
        with contextlib.suppress(Exception):  # a recorder that failed has nothing more to send
            background.submit(recorder.flush)  # the rows it held of the frames before the failure
        raise
    background.drain()  # the run's events are recorded before its evaluation
    return scored


def _run_failure(name: str, error: BaseException) -> Exception:
    """A run's unexpected error as the failure that ends the record; a plugin that exits fails its pipeline."""
    if isinstance(error, SystemExit):
        return InputError(f"pipeline {name} called sys.exit({error.code!r})")
    assert isinstance(error, Exception)
    return error


def _log_scores(stream: Any, name: str, scored: ScoredRun) -> None:
    """The run's loss causes and, with groundtruth, its error timelines, into the recording."""
    log_loss_causes(stream, name, scored.run.tracking_lost, scored.signals)
    if scored.evaluation is not None:
        log_evaluation(stream, name, scored.evaluation, scored.frame_indices, scored.frame_timestamps)


def _stage_results(
    staged: StagedFiles,
    sequence: Sequence,
    recorded: Recorded,
    names: list[str],
    trajectory_paths: dict[str, Path],
    report_path: Path,
    errors: list[str | None],
) -> dict[str, Any]:
    """Stage every finished run's trajectory and the report (which says whether the record was cut
    short or failed, and why); the report."""
    for name, scored in recorded.scored.items():  # written once a failed recording made room
        staged.write(trajectory_paths[name], partial(write_tum, trajectory=scored.run.trajectory))
    blocks = {name: scored.report for name, scored in recorded.scored.items()}
    report = build_report(
        sequence, blocks, recorded.interrupted or recorded.failure is not None or len(blocks) < len(names)
    )
    report["failed"] = any(errors)
    if report["failed"]:
        report["error"] = "; ".join(error for error in errors if error)
    staged.write(report_path, lambda path: write_report(path, report))
    return report


def _raise_failure(out: Path, report_path: Path, recording_error: str | None, failure: Exception | None) -> None:
    """Raise what ended the record early, saying what was kept of it."""
    if recording_error is not None:
        raise InputError(
            f"{out}: recording not written: {recording_error}; the report and trajectories are in {report_path.parent}"
        )
    if isinstance(failure, InputError):
        raise InputError(
            f"{failure}; the frames before it are recorded in {out}, with the report and trajectories beside it"
        )
    if failure is not None:
        raise failure


def _counts_features(run: Pipeline) -> bool:
    """Whether the run measures features, matches and inliers: an imported estimate has only poses."""
    return run.source != "estimate"
