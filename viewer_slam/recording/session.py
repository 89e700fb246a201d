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

import json
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

from .. import palette
from ..atomic import StagedFiles, check_writable, exclusive, refuse_inputs_as_outputs
from ..dataset.frame import Frame, Sequence, TimedFrames, frames_read, select_frames
from ..dataset.sources import NotABag, RgbdSequence, open_source
from ..errors import InputError
from ..geometry.trajectory import Trajectory, write_tum
from ..geometry.trajectory_formats import TrajectoryFormat
from ..pipelines.base import Pipeline
from ..runs.replay import EstimateReplay
from ..runs.report import build_report, write_report
from ..runs.selection import run_specs, select_runs
from ..runs.service import EstimateSpec, RunSpec, ScoredRun, build_run, score_run
from .blueprint import default_blueprint
from .console import RecordProgress
from .interrupt import StopRequest
from .loss_causes import log_loss_causes
from .recorder import PipelineRecorder, log_frame_image, log_world
from .rrd_file import RecordingFile
from .sizes import extent
from .timelines import log_evaluation
from .viewer import LiveViewer, live_viewer

DEMO_SCENARIO = "360_kidnap"
DEMO_FRAMES = 240
DEMO_RESOLUTION = (320, 240)
DEMO_OUT = Path("recordings/demo.rrd")

# open_bag's keywords and the flags that set them.
BAG_FLAGS = {"rgb_topic": "--rgb-topic", "depth_topic": "--depth-topic", "camera_info_topic": "--camera-info-topic",
             "groundtruth": "--groundtruth", "groundtruth_topic": "--groundtruth-topic"}
BagOptions = dict[str, Any]


@dataclass
class RecordOptions:
    """The `viewslam record` command line, as data. ``sequence=None`` is the built-in demo.

    ``pipeline=None`` runs both built-in pipelines, or none when there are ``estimates``
    (``NAME=FILE`` each, read in ``format`` or a detected one). The bag options apply to a
    ROS bag only (see :func:`~viewer_slam.dataset.rosbag.open_bag`).
    """

    sequence: str | None = None
    pipeline: str | None = None
    out: Path | None = None
    max_frames: int | None = None
    stride: int = 1
    params: list[str] = field(default_factory=list)
    config: Path | None = None
    seed: int = 0
    quiet: bool = False
    spawn: bool = False
    connect: str | None = None
    estimates: list[str] = field(default_factory=list)
    format: TrajectoryFormat | None = None
    bag: BagOptions = field(default_factory=dict)


@dataclass
class RecordResult:
    recording: Path
    report_path: Path
    trajectories: dict[str, Path]
    report: dict[str, Any]
    written: list[Path] = field(default_factory=list)
    scored: dict[str, ScoredRun] = field(default_factory=dict)

    @property
    def interrupted(self) -> bool:
        return self.report["interrupted"]


def output_path(sequence: str | None, out: Path | None) -> Path:
    """``--out``, else ``recordings/<sequence name>.rrd`` (``recordings/demo.rrd`` for the demo;
    a ROS 1 bag's name without ``.bag``)."""
    if out is not None:
        return Path(out)
    if sequence is None:
        return DEMO_OUT
    path = Path(sequence.rstrip("/"))
    return Path("recordings") / f"{path.stem if path.suffix == '.bag' else path.name}.rrd"


def check_outputs(out: Path, pipelines: list[str], inputs: dict[Path, str] | None = None) -> None:
    """Fail now, not after an hour of processing, if the recording or a file beside it cannot be
    written, or would replace one of the ``inputs`` (path -> how it was given)."""
    if out.suffix != ".rrd":
        raise InputError.at(out, "the recording must have the .rrd extension")
    if out.is_dir():
        raise InputError.at(out, "is a folder; --out takes a file name ending in .rrd")
    report, trajectories = report_paths(out, pipelines)
    refuse_inputs_as_outputs({path: "--out" for path in (out, report, *trajectories.values())},
                             inputs or {})
    for path in (out, report, *trajectories.values()):
        check_writable(path)


def open_input(sequence: str | None, bag: BagOptions | None = None, first: int | None = None,
               progress: bool = False) -> RgbdSequence:
    """The sequence to record; ``bag`` options (set ones only) for a ROS bag, an error for anything else.

    A synthetic scenario (or the demo) is rendered up to frame ``first`` only, showing
    ``progress`` on stderr.
    """
    if sequence is None:
        from ..dataset.synth import cached_scenario  # the scene renderer loads only for the demo

        source: str | Path = cached_scenario(DEMO_SCENARIO, frames=DEMO_FRAMES, resolution=DEMO_RESOLUTION,
                                             first=first, progress=progress)
    else:
        source = sequence
    try:
        return open_source(source, bag=bag, first=first, progress=progress)
    except NotABag as error:
        flag = BAG_FLAGS[error.option]
        alone = " (without SEQUENCE, --groundtruth records trajectory files alone)" if flag == "--groundtruth" else ""
        raise InputError(f"{flag}: only for a ROS bag, and {sequence or 'the demo'} is not one{alone}") from None


def report_paths(out: Path, pipelines: list[str]) -> tuple[Path, dict[str, Path]]:
    """``NAME.json`` and ``NAME.<pipeline>.txt`` beside ``NAME.rrd``."""
    return out.with_suffix(".json"), {name: out.with_name(f"{out.stem}.{name}.txt") for name in pipelines}


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
    without a sequence records trajectory files alone (:mod:`.trajectory_files`)."""
    from .trajectory_files import is_files_only, record_files  # it builds on this module

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
            with RecordProgress(total, quiet=options.quiet) as progress:
                log_world(stream, groundtruth)
                for position, name in enumerate(pipelines):
                    if stop.requested:
                        break
                    recorder = PipelineRecorder(stream, name, sequence.camera, palette.run_colour(name, position),
                                                scene_extent, tracker_counts=name in counted)

                    def on_frame(frame: Frame, recorder=recorder, first=position == 0) -> None:
                        recorder.begin_frame(frame)
                        if first:  # one copy of each image serves every pipeline's view
                            log_frame_image(stream, frame)

                    guarded = GuardedSequence(sequence)
                    try:
                        scored = score_run(guarded, runs[name], name, max_frames=options.max_frames,
                                           stride=options.stride, sinks=[recorder, progress.sink(name)],
                                           frame_sinks=[on_frame], should_stop=stop)
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
            write_staged(trajectory_paths[name], partial(write_tum, trajectory=trajectory), staged)
        report = build_report(sequence, blocks, interrupted or failure is not None or len(blocks) < len(pipelines))
        errors = [str(failure) if failure is not None else None,
                  f"{out}: {recording.error}" if recording.error is not None else None]
        report["failed"] = any(errors)
        if report["failed"]:
            report["error"] = "; ".join(error for error in errors if error)
        write_staged(report_path, lambda path: write_report(path, report), staged)
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


def earlier_trajectories(out: Path) -> list[Path]:
    """The trajectory files of the run recorded at ``out`` before, as its report lists them (none
    when it has no readable report)."""
    try:
        pipelines = json.loads(out.with_suffix(".json").read_text())["pipelines"]
        return list(report_paths(out, [str(name) for name in pipelines])[1].values())
    except (OSError, ValueError, KeyError, TypeError):
        return []


def _counts_features(run: Pipeline) -> bool:
    """Whether the run measures features, matches and inliers: an imported estimate has only poses."""
    return run.source != "estimate"


def write_staged(target: Path, write: Callable[[Path], None], staged: StagedFiles) -> None:
    """``write`` to ``target``'s temporary file; a failure (a full disk) is one line naming ``target``."""
    try:
        write(staged.path(target))
    except OSError as error:
        raise InputError.at(target, f"cannot write: {error.strerror or error}") from None
