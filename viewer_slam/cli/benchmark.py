"""`viewslam benchmark`."""

from pathlib import Path

import typer

from . import benchmark_options as bench
from .app import app
from .exits import EXIT_INTERRUPTED
from .options import QUIET_HELP, parse_resolution
from .run_options import Config, Estimates, Format, Params, Pipelines, Seed


@app.command()
def benchmark(
    sequences: bench.Sequences = None,
    pipeline: Pipelines = None,
    pipelines: bench.OldPipelines = None,
    max_frames: bench.MaxFrames = None,
    scenario_frames: bench.ScenarioFrames = None,
    resolution: bench.Resolution = "640x480",
    jobs: bench.Jobs = None,
    executor: bench.Executor = "local",
    ray_address: bench.RayAddress = None,
    out: bench.Out = Path("benchmark-results"),
    record: bench.RecordEach = False,
    param: Params = None,
    config: Config = None,
    seed: Seed = 0,
    trials: bench.Trials = 1,
    timeout: bench.Timeout = None,
    cache: bench.Cache = True,
    estimate: Estimates = None,
    format: Format = None,
    compare: bench.Compare = None,
    quiet: bool = typer.Option(False, "--quiet", help=QUIET_HELP),
) -> int:
    """Run every sequence x pipeline pair, evaluate, print the results table and write it with charts and findings.

    With --trials N, every pair runs N times (seeds SEED to SEED + N - 1) and the table gives each
    score's median and min–max. With --compare, report.md also compares every (sequence, run) row
    both folders have, and says which differences exceed the trials' spread.
    Exits with 1 when a task failed (the others still complete and are reported), 130 when
    interrupted (the finished tasks are written).
    """
    from ..benchmark.command import benchmark as run
    from ..benchmark.tables import print_results

    result = run(
        sequences or (),
        pipeline=(pipelines or []) + (pipeline or []) or None,
        max_frames=max_frames,
        scenario_frames=scenario_frames,
        resolution=parse_resolution(resolution),
        jobs=jobs,
        executor=executor,
        ray_address=ray_address,
        out=out,
        record=record,
        params=param or (),
        config=config,
        seed=seed,
        trials=trials,
        timeout=timeout,
        cache=cache,
        estimates=estimate or (),
        format=format,
        compare=compare,
        quiet=quiet,
    )
    print_results(list(result.results))
    done = len(result.results)
    summary = f"{done - result.failed} of {done} task{'s' if done != 1 else ''} ok"
    if result.interrupted:
        summary += f"; interrupted with {result.planned - done} not run"
    typer.echo(f"{summary}; wrote {', '.join(str(path) for path in result.written)}")
    return EXIT_INTERRUPTED if result.interrupted else 1 if result.failed else 0
