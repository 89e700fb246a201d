"""`viewslam benchmark`."""

from pathlib import Path

import typer

from .app import app
from .exits import EXIT_INTERRUPTED
from .options import MAX_FRAMES_HELP, QUIET_HELP, parse_resolution
from .run_options import Config, Estimates, Format, Params, Pipelines, Seed

MAX_TIMEOUT_S = 7 * 24 * 3600  # a week: beyond it a task's deadline is no deadline (and inf none at all)


@app.command()
def benchmark(
    sequences: list[str] = typer.Argument(
        None,
        help="TUM folders, TUM sequence names (fr2/360_kidnap) or synthetic scenarios; "
        "default: the seven synthetic scenarios.",
        show_default=False,
    ),
    pipeline: Pipelines = None,
    pipelines: list[str] = typer.Option([], "--pipelines", hidden=True),  # the old spelling
    max_frames: int = typer.Option(None, "--max-frames", min=2, help=MAX_FRAMES_HELP),
    scenario_frames: int = typer.Option(
        None,
        min=2,
        help="Length synthetic scenarios are rendered at, as `viewslam synth --frames` (default: their own).",
    ),
    resolution: str = typer.Option("640x480", help="Synthetic scenarios' image size, WIDTHxHEIGHT."),
    jobs: int = typer.Option(None, min=1, help="Tasks run at once (default: the number of cores)."),
    executor: str = typer.Option("local", help="local (process pool) or ray."),
    ray_address: str = typer.Option(None, help="Address of an existing Ray cluster (default: start one)."),
    out: Path = typer.Option(Path("benchmark-results"), help="Folder for results, report and charts."),
    record: bool = typer.Option(False, help="Also write a Rerun recording per task into OUT/recordings."),
    param: Params = None,
    config: Config = None,
    seed: Seed = 0,
    trials: int = typer.Option(
        1,
        min=1,
        help="Runs of every pipeline per sequence, trial k with seed SEED + k; "
        "tables and charts give the median and min–max.",
    ),
    timeout: float = typer.Option(
        None, min=1, max=MAX_TIMEOUT_S, help="Seconds after which a task is stopped and reported failed."
    ),
    cache: bool = typer.Option(True, help="Reuse results of unchanged tasks from earlier runs."),
    estimate: Estimates = None,
    format: Format = None,
    compare: Path = typer.Option(
        None,
        "--compare",
        metavar="OTHER_RESULTS_DIR",
        help="Also compare every row with the same row of an earlier benchmark's --out "
        "(in report.md), as `viewslam diff` does.",
    ),
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
        pipeline=pipelines + (pipeline or []) or None,
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
