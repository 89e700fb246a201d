"""`viewslam benchmark`."""

import re
from pathlib import Path

import typer

from ..errors import InputError
from .app import app


def parse_resolution(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not match or min(int(match.group(1)), int(match.group(2))) < 16:
        raise InputError(f"--resolution {text!r}: expected WIDTHxHEIGHT, e.g. 640x480 (at least 16 pixels each)")
    return int(match.group(1)), int(match.group(2))


def parse_pipelines(text: str) -> list[str]:
    from ..pipelines.base import pipeline_names

    names = [name.strip() for name in text.split(",") if name.strip()]
    unknown = [name for name in names if name not in pipeline_names()]
    if not names or unknown:
        raise InputError(f"--pipelines {text!r}: valid pipelines are {', '.join(pipeline_names())}")
    return list(dict.fromkeys(names))


@app.command()
def benchmark(
    sequences: list[str] = typer.Argument(
        None, help="TUM folders, TUM sequence names (fr2/360_kidnap) or synthetic scenarios; "
                   "default: the seven synthetic scenarios.", show_default=False),
    pipelines: str = typer.Option("rgbdslam,rtabmap", help="Comma-separated pipelines to run."),
    frames: int = typer.Option(None, min=2, help="Frames per sequence (synthetic: generated; TUM: the first N)."),
    resolution: str = typer.Option("640x480", help="Synthetic scenarios' image size, WIDTHxHEIGHT."),
    jobs: int = typer.Option(None, min=1, help="Tasks run at once (default: the number of cores)."),
    executor: str = typer.Option("local", help="local (process pool) or ray."),
    ray_address: str = typer.Option(None, help="Address of an existing Ray cluster (default: start one)."),
    out: Path = typer.Option(Path("benchmark-results"), help="Folder for results, report and charts."),
    record: bool = typer.Option(False, help="Also write a Rerun recording per task into OUT/recordings."),
    param: list[str] = typer.Option([], help="Pipeline parameter KEY=VALUE (repeatable)."),
    config: Path = typer.Option(None, help="TOML file of pipeline parameters."),
    seed: int = typer.Option(0, help="Seed of the pipelines' random choices."),
    timeout: float = typer.Option(None, min=1, help="Seconds after which a task is stopped and reported failed."),
    cache: bool = typer.Option(True, help="Reuse results of unchanged tasks from earlier runs."),
    quiet: bool = typer.Option(False, help="No progress bar."),
) -> int:
    """Run every sequence x pipeline pair, evaluate, and write the study's table, charts and findings.

    Exits with 1 when a task failed (the others still complete and are reported).
    """
    from ..benchmark.cache import ResultCache
    from ..benchmark.plan import plan_tasks
    from ..benchmark.report import write_outputs
    from ..benchmark.executors import make_executor
    from ..benchmark.suite import run_benchmark

    runner = make_executor(executor, jobs, ray_address)  # checks the options before any scenario is generated
    tasks = plan_tasks(sequences or None, parse_pipelines(pipelines), frames=frames,
                       resolution=parse_resolution(resolution), assignments=param, config=config, seed=seed,
                       timeout_s=timeout, recordings=out / "recordings" if record else None)
    results = run_benchmark(tasks, runner, ResultCache() if cache else None, progress=not quiet)
    paths = write_outputs(results, out)
    failed = sum(not result.ok for result in results)
    typer.echo(f"{len(results) - failed} of {len(results)} tasks ok; report: {paths['report']}")
    return 1 if failed else 0
