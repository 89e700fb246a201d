"""``viewslam record`` as a library function: the arguments checked and read into typed inputs
once, here, then handed down (:mod:`.session` for runs over a sequence, :mod:`.files` for
trajectory files alone)."""

from collections.abc import Sequence
from pathlib import Path

from ..errors import InputError
from ..geometry.trajectory_formats import TrajectoryFormat
from ..rerun_adapter.viewer import live_viewer
from ..runs.replay import named_estimates
from ..runs.run_specs import run_specs, select_runs
from .files import FILES_ONLY, record_trajectory_files
from .inputs import BagTopics
from .options import FrameSelection, RecordResult
from .outputs import output_path
from .session import record_runs


def record(
    sequence: str | Path | None = None,
    *,
    pipeline: str | Sequence[str] | None = None,
    estimates: Sequence[str] = (),
    format: TrajectoryFormat | None = None,
    out: Path | None = None,
    max_frames: int | None = None,
    stride: int = 1,
    params: Sequence[str] = (),
    config: Path | None = None,
    seed: int = 0,
    quiet: bool = True,
    spawn: bool = False,
    connect: str | None = None,
    bag: BagTopics = BagTopics(),
    groundtruth: Path | None = None,
) -> RecordResult:
    """Run SLAM pipelines over ``sequence`` into one Rerun recording ``out`` (default
    ``recordings/<sequence>.rrd``), with the report ``NAME.json`` and a trajectory per run beside it.

    ``sequence`` is a TUM folder, a ROS bag, a synthetic scenario or a TUM sequence name (None:
    the built-in demo); ``pipeline`` names the runs (comma-separated or a list; default both
    built-in pipelines, or none beside ``estimates``, each ``NAME=FILE``, another system's
    trajectory replayed as a run and read in ``format`` or a detected one). ``params`` are
    ``KEY=VALUE`` under each pipeline's original names, applied after the TOML ``config``.
    ``max_frames`` and ``stride`` select the frames; ``seed`` seeds every random choice;
    ``quiet`` hides the progress on stderr; ``spawn`` or ``connect`` (HOST:PORT) also stream
    live into a Rerun viewer. ``bag`` picks a ROS bag's topics; ``groundtruth`` is a bag's
    groundtruth file, or, with no ``sequence``, records the ``estimates`` alone against it,
    scored as :func:`~viewer_slam.runs.evaluate_command.evaluate` scores them.

    Everything that can be wrong is checked before the first frame; bad input is an
    :class:`~viewer_slam.errors.InputError` naming it. The result says what was written and
    whether a stop request cut the run short.
    """
    choice = pipeline if pipeline is None or isinstance(pipeline, str) else ",".join(pipeline)
    frames = FrameSelection(max_frames, stride)
    if sequence is None and groundtruth is not None:
        _check_files_only(groundtruth, choice, estimates, frames, params, config, bag)
        target = Path(out) if out is not None else Path("recordings") / f"{Path(groundtruth).stem}.rrd"
        return record_trajectory_files(
            Path(groundtruth),
            named_estimates(list(estimates), []),
            target,
            format=format,
            quiet=quiet,
            viewer=live_viewer(spawn, connect, target),
        )
    pipelines, named = select_runs(choice, estimates)
    specs = run_specs(pipelines, named, assignments=params, config=config, seed=seed, format=format)
    source = None if sequence is None else str(sequence)
    target = output_path(source, out)
    return record_runs(
        source,
        specs,
        target,
        frames=frames,
        quiet=quiet,
        bag=bag,
        groundtruth=groundtruth,
        config=config,
        viewer=live_viewer(spawn, connect, target),
    )


def _check_files_only(
    groundtruth: Path,
    pipeline: str | None,
    estimates: Sequence[str],
    frames: FrameSelection,
    params: Sequence[str],
    config: Path | None,
    bag: BagTopics,
) -> None:
    """Refuse, in one line naming the option, what a recording of trajectory files alone cannot use."""
    if pipeline is not None:
        raise InputError(f"--pipeline: {FILES_ONLY} has no images to run a pipeline on; give SEQUENCE to run one")
    if not estimates:
        raise InputError(f"--groundtruth {groundtruth}: {FILES_ONLY} needs at least one --estimate NAME=FILE")
    frame_options = {
        "--max-frames": frames.max_frames is not None,
        "--stride": frames.stride != 1,
        "--param": bool(params),
        "--config": config is not None,
    }
    for flag, given in frame_options.items():
        if given:
            raise InputError(f"{flag}: applies to a sequence's frames and pipelines; {FILES_ONLY} has neither")
    for flag in bag.given():
        raise InputError(f"{flag}: only for a ROS bag given as SEQUENCE")
