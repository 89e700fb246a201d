"""Reproduce the study: the seven synthetic situations x both pipelines, charts into docs/images.

    .venv/bin/python benchmarks/study.py [--frames N] [--resolution WxH] [--jobs N] [--out DIR]

Generates the scenarios first, one process per job (rendering dominates a cold run), then
runs ``viewslam benchmark`` on them and copies its charts to ``docs/images/``.
"""

import argparse
import shutil
import sys
from concurrent.futures import ProcessPoolExecutor
from functools import partial
from pathlib import Path

from viewer_slam.cli import main
from viewer_slam.cli.options import parse_resolution
from viewer_slam.dataset.synth import SCENARIOS, cached_scenario

IMAGES = Path(__file__).resolve().parent.parent / "docs" / "images"


def run(arguments: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=None, help="frames per scenario (default: each one's own)")
    parser.add_argument("--resolution", default="640x480")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path("benchmark-results/study"))
    options = parser.parse_args(arguments)
    generate = partial(cached_scenario, frames=options.frames, resolution=parse_resolution(options.resolution))
    with ProcessPoolExecutor(options.jobs) as pool:
        for name, folder in zip(SCENARIOS, pool.map(generate, SCENARIOS)):
            print(f"{name}: {folder}", flush=True)
    size = ["--scenario-frames", str(options.frames)] if options.frames else []
    code = main(["benchmark", *size, "--resolution", options.resolution, "--jobs", str(options.jobs),
                 "--out", str(options.out)])
    IMAGES.mkdir(parents=True, exist_ok=True)
    for chart in sorted(options.out.glob("benchmark_*")):
        shutil.copy2(chart, IMAGES / chart.name)
    return code


if __name__ == "__main__":
    sys.exit(run(sys.argv[1:]))
