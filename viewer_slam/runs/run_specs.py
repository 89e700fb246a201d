"""Which runs a command makes: ``--pipeline`` and ``--estimate NAME=FILE``, read the same way by
``record`` and ``benchmark``, and turned into validated run descriptions once, at the edge."""

import sys
from collections.abc import Sequence
from pathlib import Path

from ..geometry.trajectory_formats import TrajectoryFormat
from ..pipelines.base import pipeline_class
from ..pipelines.params import resolve_params
from ..pipelines.pipeline_option import BOTH, select_pipelines
from .replay import named_estimates
from .service import EstimateSpec, PipelineSpec, RunSpec


def select_runs(choice: str | None, estimates: Sequence[str]) -> tuple[list[str], list[tuple[str, Path]]]:
    """The pipelines (``--pipeline``; by default both, or none beside estimates) and the
    estimates (``--estimate NAME=FILE``); every name must be unique among them."""
    pipelines = select_pipelines(choice) if choice is not None else [] if estimates else select_pipelines(BOTH)
    return pipelines, named_estimates(list(estimates), pipelines)


def run_specs(
    pipelines: list[str],
    estimates: list[tuple[str, Path]],
    *,
    assignments: Sequence[str] = (),
    config: Path | None = None,
    seed: int = 0,
    format: TrajectoryFormat | None = None,
) -> dict[str, RunSpec]:
    """The runs by name: the pipelines with their parameters validated (defaults, then ``config``,
    then ``assignments``, each ``KEY=VALUE``), then the estimates, read in ``format`` (None: detected)."""
    params = resolve_params({name: pipeline_class(name).Params for name in pipelines}, assignments, config)
    specs: dict[str, RunSpec] = {name: PipelineSpec(name, params[name], seed) for name in pipelines}
    specs.update({name: EstimateSpec(file, format) for name, file in estimates})
    return specs


def say_estimate_format(name: str, path: Path | str, format: str | None, given: bool) -> None:
    """On stderr, the format an estimate file was read as, and whether --format gave it or it was
    detected: the one line `record` and `benchmark` print for each estimate."""
    print(f"estimate {name}: {path} read as {format} ({'given' if given else 'detected'})", file=sys.stderr)
