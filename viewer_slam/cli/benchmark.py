"""`viewslam benchmark`."""

from pathlib import Path

import typer

from ..errors import InputError
from ..geometry.trajectory_formats import TrajectoryFormat
from .app import app
from .options import MAX_FRAMES_HELP, PIPELINE_HELP, QUIET_HELP, SEED_MAX, parse_resolution

MAX_TIMEOUT_S = 7 * 24 * 3600  # a week: beyond it a task's deadline is no deadline (and inf none at all)


@app.command()
def benchmark(
    sequences: list[str] = typer.Argument(
        None, help="TUM folders, TUM sequence names (fr2/360_kidnap) or synthetic scenarios; "
                   "default: the seven synthetic scenarios.", show_default=False),
    pipeline: list[str] = typer.Option([], "--pipeline", help=PIPELINE_HELP + "  [default: both]"),
    pipelines: list[str] = typer.Option([], "--pipelines", hidden=True),  # the old spelling
    max_frames: int = typer.Option(None, "--max-frames", min=2, help=MAX_FRAMES_HELP),
    scenario_frames: int = typer.Option(None, min=2, help="Length synthetic scenarios are rendered at, as "
                                                           "`viewslam synth --frames` (default: their own)."),
    resolution: str = typer.Option("640x480", help="Synthetic scenarios' image size, WIDTHxHEIGHT."),
    jobs: int = typer.Option(None, min=1, help="Tasks run at once (default: the number of cores)."),
    executor: str = typer.Option("local", help="local (process pool) or ray."),
    ray_address: str = typer.Option(None, help="Address of an existing Ray cluster (default: start one)."),
    out: Path = typer.Option(Path("benchmark-results"), help="Folder for results, report and charts."),
    record: bool = typer.Option(False, help="Also write a Rerun recording per task into OUT/recordings."),
    param: list[str] = typer.Option([], help="Pipeline parameter KEY=VALUE (repeatable)."),
    config: Path = typer.Option(None, help="TOML file of pipeline parameters."),
    seed: int = typer.Option(0, min=0, max=SEED_MAX, help="Seed of the pipelines' random choices."),
    trials: int = typer.Option(1, min=1, help="Runs of every pipeline per sequence, trial k with seed SEED + k; "
                                              "tables and charts give the median and min–max."),
    timeout: float = typer.Option(None, min=1, max=MAX_TIMEOUT_S,
                                  help="Seconds after which a task is stopped and reported failed."),
    cache: bool = typer.Option(True, help="Reuse results of unchanged tasks from earlier runs."),
    estimate: list[str] = typer.Option([], "--estimate", metavar="NAME=FILE",
                                       help="Another system's trajectory of the one SEQUENCE, scored as a row "
                                            "(repeatable); with estimates, no built-in pipeline runs unless "
                                            "--pipeline asks."),
    format: TrajectoryFormat | None = typer.Option(None, "--format", help="Format of the estimates (default: "
                                                                          "detected)."),
    compare: Path = typer.Option(None, "--compare", metavar="OTHER_RESULTS_DIR",
                                 help="Also compare every row with the same row of an earlier benchmark's --out "
                                      "(in report.md), as `viewslam diff` does."),
    quiet: bool = typer.Option(False, "--quiet", help=QUIET_HELP),
) -> int:
    """Run every sequence x pipeline pair, evaluate, print the results table and write it with charts and findings.

    With --trials N, every pair runs N times (seeds SEED to SEED + N - 1) and the table gives each
    score's median and min–max. With --compare, report.md also compares every (sequence, run) row
    both folders have, and says which differences exceed the trials' spread.
    Exits with 1 when a task failed (the others still complete and are reported), 130 when
    interrupted (the finished tasks are written).
    """
    from ..atomic import check_writable, exclusive, refuse_inputs_as_outputs
    from ..benchmark.cache import ResultCache
    from ..benchmark.executors import make_executor
    from ..benchmark.plan import plan_tasks
    from ..benchmark.report import OUTPUT_FILES, RECORDINGS_FOLDER, planned_outputs, write_outputs
    from ..benchmark.suite import run_benchmark
    from ..benchmark.tables import print_results
    from ..comparison.results import check_planned_sequences, load_results
    from ..dataset.sources import open_source
    from ..runs.report import sequence_block
    from ..runs.selection import select_runs

    runner = make_executor(executor, jobs, ray_address)  # checks the options before any scenario is generated
    if seed + trials - 1 > SEED_MAX:
        raise InputError(f"--trials {trials} with --seed {seed}: the last trial's seed {seed + trials - 1} is beyond "
                         f"{SEED_MAX}")
    chosen = pipelines + pipeline
    names, estimates = select_runs(",".join(chosen) if chosen else None, estimate)
    other = load_results(compare) if compare is not None else None
    if out.exists() and not out.is_dir():
        raise InputError.at(out, "is a file; --out takes a folder")
    for name in OUTPUT_FILES:
        check_writable(out / name)
    with exclusive([out]):
        tasks = plan_tasks(sequences or None, names, max_frames=max_frames, scenario_frames=scenario_frames,
                           resolution=parse_resolution(resolution), assignments=param, config=config, seed=seed,
                           timeout_s=timeout, recordings=out / RECORDINGS_FOLDER if record else None,
                           estimates=estimates, estimate_format=format, trials=trials, progress=not quiet)
        refuse_inputs_as_outputs(planned_outputs(out, tasks),
                                 {**{task.estimate: f"--estimate {task.pipeline}={task.estimate}" for task in tasks
                                     if task.estimate is not None},
                                  **({config: f"--config {config}"} if config is not None else {})})
        if not quiet:
            for task in tasks:
                if task.estimate is not None:
                    typer.echo(f"estimate {task.pipeline}: {task.estimate} read as {task.estimate_format} "
                               f"({'given' if format else 'detected'})", err=True)
        if other is not None:
            folders = {task.name: task.sequence for task in tasks}
            check_planned_sequences(other, {name: sequence_block(open_source(folder))
                                            for name, folder in folders.items()})
        outcome = run_benchmark(tasks, runner, ResultCache() if cache else None, progress=not quiet)
        paths = write_outputs(outcome.results, out, compare_with=other, recorded=record)
    print_results(outcome.results)
    failed = sum(not result.ok for result in outcome.results)
    done = len(outcome.results)
    summary = f"{done - failed} of {done} task{'s' if done != 1 else ''} ok"
    if outcome.interrupted:
        summary += f"; interrupted with {len(tasks) - done} not run"
    typer.echo(f"{summary}; wrote {', '.join(str(path) for path in paths)}")
    return 130 if outcome.interrupted else 1 if failed else 0
