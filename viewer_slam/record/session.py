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

import sys
from collections.abc import Iterator
from functools import partial
from pathlib import Path

from .. import palette
from ..atomic import StagedFiles, exclusive
from ..dataset.frame import Frame, Sequence, TimedFrames, frames_read, select_frames
from ..errors import InputError
from ..geometry.trajectory import Trajectory, write_tum
from ..pipelines.base import Pipeline
from ..recording.background import RecordingThread
from ..recording.blueprint import default_blueprint
from ..recording.loss_causes import log_loss_causes
from ..recording.recorder import PipelineRecorder, log_frame_image, log_world
from ..recording.rrd_file import RecordingFile
from ..recording.sizes import extent
from ..recording.timelines import log_evaluation
from ..recording.viewer import LiveViewer, live_viewer
from ..runs.replay import EstimateReplay
from ..runs.report import build_report, write_report
from ..runs.selection import run_specs, select_runs
from ..runs.service import EstimateSpec, RunSpec, ScoredRun, build_run, score_run
from .console import RecordProgress
from .files import is_files_only, record_files
from .inputs import open_input
from .interrupt import StopRequest
from .options import RecordOptions, RecordResult
from .outputs import check_outputs, earlier_trajectories, output_path, report_paths


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
            for frame in self._sequence.frames(max_frames=max_frames, stride=stride):
                self.read += 1
                yield frame
        except InputError as error:
            self.error = error


def record(options: RecordOptions) -> RecordResult:
    """Check the options, then record every selected run (see the module docstring); ``--groundtruth``
    without a sequence records trajectory files alone (:mod:`.files`)."""

    if is_files_only(options):
        return record_files(options)
    pipelines, estimates = select_runs(options.pipeline, options.estimates)
    return record_runs(options, run_specs(pipelines, estimates, assignments=options.params, config=options.config,
                                          seed=options.seed, format=options.format))


def record_runs(options: RecordOptions, specs: dict[str, RunSpec]) -> RecordResult:
    """Record the runs ``specs`` over ``options.sequence``; the options' own run selection is not read.

    The outputs are checked before the sequence is opened, and every run is built (an estimate
    file read) before the first frame.
    """
    out = output_path(options.sequence, options.out)
    viewer = live_viewer(options.spawn, options.connect, out)
    inputs = {Path(spec.file): f"--estimate {name}={spec.file}" for name, spec in specs.items()
              if isinstance(spec, EstimateSpec)}
    if options.config is not None:
        inputs[Path(options.config)] = f"--config {options.config}"
    if options.sequence is not None and Path(options.sequence).exists():
        inputs[Path(options.sequence)] = f"the sequence {options.sequence}"
    check_outputs(out, list(specs), inputs)
    with exclusive([out]):
        sequence = open_input(options.sequence, options.bag, first=frames_read(options.max_frames, options.stride),
                              progress=not options.quiet)
        runs = {name: build_run(spec, sequence, max_frames=options.max_frames, stride=options.stride)
                for name, spec in specs.items()}
        if not options.quiet:
            how = "given" if options.format else "detected"
            for name, run in runs.items():
                if isinstance(run, EstimateReplay):
                    print(f"estimate {name}: {run.params.file} read as {run.params.format} ({how})",
                          file=sys.stderr)
        return record_sequence(sequence, runs, out, options, viewer)


def record_sequence(sequence: Sequence, runs: dict[str, Pipeline], out: Path, options: RecordOptions,
                    viewer: LiveViewer | None = None) -> RecordResult:
    """Record the ``runs`` (name -> pipeline or estimate replay), in order, over ``sequence``.

    Uses ``options`` for the frame selection, seed and progress; ``out`` is trusted; ``viewer``
    is also shown the recording live.
    Every file is written under a temporary name and renamed into place at the end (also
    after a stop request or a failure mid-run), so a run that fails before its first frame
    leaves the previous outputs as they were.
    """
    pipelines = list(runs)
    report_path, trajectory_paths = report_paths(out, pipelines)
    blocks: dict[str, dict] = {}
    scored_runs: dict[str, ScoredRun] = {}
    trajectories: dict[str, Trajectory] = {}
    interrupted = False
    failure: Exception | None = None
    groundtruth = sequence.groundtruth
    counted = [name for name in pipelines if _counts_features(runs[name])]
    blueprint = default_blueprint(pipelines, None if groundtruth is None else groundtruth.poses, counted)
    scene_extent = None if groundtruth is None else extent(groundtruth.positions)
    total = len(select_frames(len(sequence), options.max_frames, options.stride))
    earlier = earlier_trajectories(out)
    with StagedFiles() as staged, StopRequest().installed() as stop:
        recording = RecordingFile(staged.path(out), out, blueprint, viewer)
        stream = recording.stream
        try:
            with RecordProgress(total, quiet=options.quiet) as progress, RecordingThread() as background:
                log_world(stream, groundtruth)
                for position, name in enumerate(pipelines):
                    if stop.requested:
                        break
                    recorder = PipelineRecorder(stream, name, sequence.camera, palette.run_colour(name, position),
                                                scene_extent, tracker_counts=name in counted)

                    def on_frame(frame: Frame, recorder=recorder, first=position == 0) -> None:
                        background.submit(recorder.begin_frame, frame)
                        if first:  # one copy of each image serves every pipeline's view
                            background.submit(log_frame_image, stream, frame)

                    guarded = GuardedSequence(sequence)
                    try:
                        scored = score_run(guarded, runs[name], name, max_frames=options.max_frames,
                                           stride=options.stride, sinks=[background.sink(recorder), progress.sink(name)],
                                           frame_sinks=[on_frame], should_stop=stop)
                        background.drain()  # the run's events are recorded before its evaluation
                    except (Exception, SystemExit) as error:  # an unexpected failure: keep what was recorded
                        if isinstance(error, SystemExit):  # a plugin that exits: that pipeline's failure
                            error = InputError(f"pipeline {name} called sys.exit({error.code!r})")
                        if not blocks and not guarded.read:
                            raise error
                        failure = error
                        break
                    run = scored.run
                    failure = guarded.error
                    if failure is not None and not run.frames:
                        raise failure  # not one frame was read: there is nothing to keep
                    interrupted = interrupted or run.interrupted or failure is not None
                    log_loss_causes(stream, name, run.tracking_lost, scored.signals)
                    if scored.evaluation is not None:
                        log_evaluation(stream, name, scored.evaluation, scored.frame_indices, scored.frame_timestamps)
                    blocks[name] = scored.report
                    scored_runs[name] = scored
                    trajectories[name] = run.trajectory
                    if failure is not None:
                        break
        finally:
            recording.close()
        if recording.error is not None:
            staged.discard(out)  # an incomplete file that readers refuse; the previous one stays
        for name, trajectory in trajectories.items():  # written once a failed recording made room
            staged.write(trajectory_paths[name], partial(write_tum, trajectory=trajectory))
        report = build_report(sequence, blocks, interrupted or failure is not None or len(blocks) < len(pipelines))
        errors = [str(failure) if failure is not None else None,
                  f"{out}: {recording.error}" if recording.error is not None else None]
        report["failed"] = any(errors)
        if report["failed"]:
            report["error"] = "; ".join(error for error in errors if error)
        staged.write(report_path, lambda path: write_report(path, report))
        staged.commit()
    for path in set(earlier) - {trajectory_paths[name] for name in trajectories}:
        path.unlink(missing_ok=True)  # the earlier run's, which the report now in place does not list
    written = [path for path in (out, report_path, *trajectory_paths.values()) if path.exists()]
    if recording.error is not None:
        raise InputError(f"{out}: recording not written: {recording.error}; the report and trajectories "
                         f"are in {report_path.parent}")
    if isinstance(failure, InputError):
        raise InputError(f"{failure}; the frames before it are recorded in {out}, with the report and "
                         f"trajectories beside it")
    if failure is not None:
        raise failure
    return RecordResult(out, report_path, {name: trajectory_paths[name] for name in blocks}, report, written,
                        scored_runs)


def _counts_features(run: Pipeline) -> bool:
    """Whether the run measures features, matches and inliers: an imported estimate has only poses."""
    return run.source != "estimate"
