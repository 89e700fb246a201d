"""What the lab's scripts share with ``viewslam record``: one way to set a pipeline's parameters,
one way to run it, and one way to end on bad input; and the measures they all take (an ATE
RMSE, the process's CPU time).

Parameters are read as the command line reads them (:func:`viewer_slam.pipelines.params.resolve_params`):
the defaults, then ``--config FILE`` (a TOML file, flat keys or one table per pipeline), then
``--param KEY=VALUE`` (repeatable). A script that replays another system's configuration lays it
down as the first ``--param`` values, so the user's own come on top. A run goes through the run
service (:mod:`viewer_slam.runs.service`): built from its description, driven, its losses
diagnosed and its trajectory scored, as every run of ``record`` and ``benchmark`` is.
"""

import argparse
import os
import sys
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, NoReturn

from viewer_slam.dataset.frame import Sequence as FrameSequence
from viewer_slam.errors import InputError
from viewer_slam.evaluation import ErrorSeries, evaluate
from viewer_slam.geometry.trajectory import Trajectory
from viewer_slam.pipelines.base import pipeline_class
from viewer_slam.pipelines.params import resolve_params
from viewer_slam.pipelines.run import Sink
from viewer_slam.runs.service import PipelineSpec, RunSpec, ScoredRun, build_run, score_run

EXIT_BAD_INPUT = 2


def add_parameter_options(parser: argparse.ArgumentParser, applies_to: str = "the pipelines that have KEY") -> None:
    """``--param KEY=VALUE`` (repeatable) and ``--config FILE``, as ``viewslam record`` takes them."""
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help=f"a parameter for {applies_to}, as `viewslam record --param` (repeatable; on top of --config)",
    )
    parser.add_argument(
        "--config", type=Path, metavar="FILE.toml", help="parameters from a TOML file, as `viewslam record --config`"
    )


def pipeline_specs(
    pipelines: Sequence[str],
    options: argparse.Namespace | None = None,
    *,
    preset: Mapping[str, Any] | None = None,
    last: Mapping[str, Any] | None = None,
    seed: int = 0,
) -> dict[str, PipelineSpec]:
    """Each of ``pipelines`` with its parameters validated: the defaults, ``--config``, then
    ``preset`` (a configuration the script replays), ``--param``, and ``last`` (what the script
    itself varies), each as ``--param`` values; without ``options``, no ``--config`` and no ``--param``."""
    given = options or argparse.Namespace(param=[], config=None)
    assignments = [*_assignments(preset), *given.param, *_assignments(last)]
    params = resolve_params({name: pipeline_class(name).Params for name in pipelines}, assignments, given.config)
    return {name: PipelineSpec(name, params[name], seed) for name in pipelines}


def pipeline_spec(
    pipeline: str,
    options: argparse.Namespace | None = None,
    *,
    preset: Mapping[str, Any] | None = None,
    last: Mapping[str, Any] | None = None,
    seed: int = 0,
) -> PipelineSpec:
    """One pipeline's run description (see :func:`pipeline_specs`)."""
    return pipeline_specs([pipeline], options, preset=preset, last=last, seed=seed)[pipeline]


def _assignments(values: Mapping[str, Any] | None) -> list[str]:
    return [f"{key}={value}" for key, value in (values or {}).items()]


def run(
    sequence: FrameSequence, spec: RunSpec, name: str, *, max_frames: int | None = None, sinks: Iterable[Sink] = ()
) -> ScoredRun:
    """The run ``spec`` describes (a pipeline, or an estimate file replayed), called ``name``,
    driven over ``sequence``'s first ``max_frames`` frames by the run service and scored."""
    return score_run(
        sequence, build_run(spec, sequence, max_frames=max_frames), name, max_frames=max_frames, sinks=sinks
    )


def rmse(series: ErrorSeries | None) -> float:
    """The RMSE of an error series; NaN for none (no groundtruth, no pose paired with it)."""
    return float("nan") if series is None else float(series.stats()["rmse"])


def ate_rmse(groundtruth: Trajectory | None, trajectory: Trajectory | None) -> float:
    """ATE RMSE (m) of ``trajectory`` against ``groundtruth``, as ``viewslam evaluate`` scores it by
    default; NaN without either or without a pose."""
    if groundtruth is None or trajectory is None or not len(trajectory):
        return float("nan")
    return rmse(evaluate(groundtruth, trajectory).ate)


def arguments(argv: list[str] | None) -> list[str]:
    """The arguments a script's ``main`` was given: ``argv``, or the command line's."""
    return sys.argv[1:] if argv is None else argv


def process_cpu_s() -> float:
    """CPU seconds of this process: the speed on an otherwise idle core, which other load on a
    shared machine does not inflate."""
    times = os.times()
    return times.user + times.system


def main_of(main: Callable[[list[str] | None], int | None]) -> NoReturn:
    """Run a script's ``main`` on the command line: bad input ends in one line on stderr and
    exit code 2, as with ``viewslam``."""
    try:
        code = main(None)
    except InputError as error:
        print(f"error: {error}", file=sys.stderr)
        sys.exit(EXIT_BAD_INPUT)
    sys.exit(code or 0)
