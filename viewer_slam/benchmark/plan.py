"""Turn command-line choices into the list of (sequence, pipeline) tasks."""

from pathlib import Path

from ..dataset.catalog import resolve_sequence, study_scenarios
from ..pipelines.base import pipeline_class
from ..pipelines.params import params_to_dict, resolve_params
from .runner import BenchmarkTask

# Synthetic scenarios are always generated with this seed, so every benchmark scores the
# same data; `--seed` varies the pipelines' random choices only.
SCENARIO_SEED = 0


def plan_tasks(specs: list[str] | None, pipelines: list[str], *, max_frames: int | None = None,
               scenario_frames: int | None = None, resolution: tuple[int, int] = (640, 480),
               assignments: list[str] = (), config: Path | None = None, seed: int = 0,
               timeout_s: float | None = None, recordings: Path | None = None) -> list[BenchmarkTask]:
    """One task per sequence and pipeline, sequence-major; ``specs`` None means the synthetic scenarios.

    ``max_frames`` cuts every sequence, recorded or synthetic, to its first frames (as
    `viewslam record --max-frames` does); ``scenario_frames`` is the length synthetic
    scenarios are rendered at (default: each scenario's own). Parameters come from the
    pipelines' defaults, then ``config``, then ``assignments`` (``KEY=VALUE``), and are
    resolved here so a bad key fails before anything runs.
    """
    params = resolve_params({name: pipeline_class(name).Params for name in pipelines}, assignments, config)
    tasks = []
    for spec in specs or study_scenarios():
        folder = resolve_sequence(spec, frames=scenario_frames, resolution=resolution, seed=SCENARIO_SEED)
        name = folder.name if Path(spec).expanduser().is_dir() else spec
        for pipeline in pipelines:
            recording = recordings / f"{name.replace('/', '_')}.{pipeline}.rrd" if recordings is not None else None
            tasks.append(BenchmarkTask(name=name, sequence=folder, pipeline=pipeline,
                                       parameters=params_to_dict(params[pipeline]), seed=seed, max_frames=max_frames,
                                       timeout_s=timeout_s, recording=recording))
    return tasks
