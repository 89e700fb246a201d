"""Turn command-line choices into the list of (sequence, pipeline, trial) tasks."""

from collections.abc import Sequence
from pathlib import Path

from ..dataset.catalog import study_scenarios
from ..dataset.frame import frames_read
from ..dataset.sources import open_source
from ..errors import InputError
from ..pipelines.base import pipeline_class
from ..pipelines.params import resolve_params
from ..runs.replay import estimate_replay
from .runner import BenchmarkTask, SequenceSource, recording_path

# Synthetic scenarios are always generated with this seed, so every benchmark scores the
# same data; `--seed` varies the pipelines' random choices only.
SCENARIO_SEED = 0


def plan_tasks(
    specs: list[str] | None,
    pipelines: list[str],
    *,
    max_frames: int | None = None,
    scenario_frames: int | None = None,
    resolution: tuple[int, int] = (640, 480),
    assignments: Sequence[str] = (),
    config: Path | None = None,
    seed: int = 0,
    timeout_s: float | None = None,
    recordings: Path | None = None,
    estimates: Sequence[tuple[str, Path]] = (),
    estimate_format: str | None = None,
    trials: int = 1,
    progress: bool = False,
) -> list[BenchmarkTask]:
    """``trials`` tasks per sequence and pipeline, sequence-major; ``specs`` None means the synthetic scenarios.

    Trial k runs with the seed :func:`trial_seed` gives; with one trial the tasks carry no
    trial index, as a benchmark without trials plans them.

    ``estimates`` (name, file) are trajectories of one sequence: each is one more task after
    the pipelines', so there must be exactly one sequence.

    ``max_frames`` cuts every sequence, recorded or synthetic, to its first frames (as
    `viewslam record --max-frames` does); ``scenario_frames`` is the length synthetic
    scenarios are rendered at (default: each scenario's own), of which only the first
    ``max_frames`` are rendered, with ``progress`` on stderr. Parameters come from the
    pipelines' defaults, then ``config``, then ``assignments`` (``KEY=VALUE``), and are
    resolved here so a bad key fails before anything runs.
    """
    params = resolve_params({name: pipeline_class(name).Params for name in pipelines}, assignments, config)
    seeds = {trial: trial_seed(seed, trial) for trial in range(trials)}
    if estimates and len(specs or study_scenarios()) != 1:
        raise InputError(
            f"--estimate: an estimate is a trajectory of one sequence; give exactly one SEQUENCE "
            f"(got {len(specs or study_scenarios())})"
        )
    tasks = []
    for spec in specs or study_scenarios():
        catalogued = SequenceSource(spec, scenario_frames, resolution, SCENARIO_SEED, frames_read(max_frames))
        folder = catalogued.resolve(progress=progress)
        name = folder.name if Path(spec).expanduser().is_dir() else spec
        source = None if Path(spec).expanduser().exists() else catalogued  # a path: no other way to find it
        for pipeline in pipelines:
            for trial, seed_of_trial in seeds.items():
                index = trial if trials > 1 else None
                tasks.append(
                    BenchmarkTask(
                        name=name,
                        sequence=folder,
                        pipeline=pipeline,
                        params=params[pipeline],
                        seed=seed_of_trial,
                        max_frames=max_frames,
                        timeout_s=timeout_s,
                        recording=_recording(recordings, name, pipeline, index),
                        trial=index,
                        source=source,
                    )
                )
        for estimate, file in estimates:
            # Read now: a file that is no trajectory fails before any task runs, and its format is settled.
            replay = estimate_replay(open_source(folder), file, estimate_format, max_frames=max_frames)
            tasks.append(
                BenchmarkTask(
                    name=name,
                    sequence=folder,
                    pipeline=estimate,
                    max_frames=max_frames,
                    timeout_s=timeout_s,
                    recording=_recording(recordings, name, estimate),
                    estimate=file,
                    estimate_format=replay.params.format,
                    source=source,
                )
            )
    return tasks


def trial_seed(seed: int, trial: int) -> int:
    """The seed of trial ``trial`` (from 0) of a benchmark given ``--seed seed``: ``seed + trial``.

    Trial 0 is the run ``--seed seed`` alone gives, and the trials of ``--seed 5 --trials 3``
    (seeds 5, 6, 7) are runs a benchmark with ``--seed 6`` shares, so the cache serves them.
    """
    return seed + trial


def _recording(recordings: Path | None, name: str, run: str, trial: int | None = None) -> Path | None:
    """Where a task records its run, when the benchmark records: one .rrd per sequence, run and trial."""
    return recording_path(recordings, name, run, trial) if recordings is not None else None
