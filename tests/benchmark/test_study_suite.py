"""The study end to end with the real pipelines on the seven synthetic situations (small size)."""

import csv
import json
import shutil
from pathlib import Path

import pytest
from benchmark_fake_pipeline import MODULE, FakeParams

from viewer_slam.benchmark.executors import LocalExecutor, RayExecutor, run_tasks
from viewer_slam.benchmark.plan import plan_tasks
from viewer_slam.benchmark.plots import CHARTS
from viewer_slam.benchmark.runner import BenchmarkTask
from viewer_slam.benchmark.tables import COLUMNS
from viewer_slam.cli import main
from viewer_slam.dataset.catalog import resolve_sequence
from viewer_slam.dataset.synth import STUDY_SCENARIOS as SCENARIOS
from viewer_slam.pipelines import base

FRAMES, RESOLUTION = 40, "160x120"
SIZE = ["--scenario-frames", str(FRAMES), "--resolution", RESOLUTION]

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def cache_root(tmp_path_factory):
    """One cache for the module, so the scenarios are generated once."""
    return tmp_path_factory.mktemp("cache")


@pytest.fixture(autouse=True)
def cache(cache_root, monkeypatch):
    monkeypatch.setenv("VIEWSLAM_CACHE", str(cache_root))


def corrupted_copy(tmp_path: Path) -> Path:
    """A scenario whose tenth colour image is cut short, as an interrupted copy leaves it."""
    folder = shutil.copytree(
        resolve_sequence("sitting_static", frames=FRAMES, resolution=(160, 120)), tmp_path / "corrupted"
    )
    image = sorted((folder / "rgb").iterdir())[9]
    image.write_bytes(image.read_bytes()[:200])
    return folder


def test_seven_situations_two_pipelines(tmp_path, capsys):
    corrupted = corrupted_copy(tmp_path)
    out = tmp_path / "out"
    arguments = ["benchmark", *SCENARIOS, str(corrupted), *SIZE, "--jobs", "2", "--out", str(out), "--quiet"]
    assert main(arguments) == 1  # a task failed; all others completed
    with open(out / "results.csv", newline="") as handle:
        reader = csv.DictReader(handle)
        rows = list(reader)
    assert reader.fieldnames == list(COLUMNS)
    assert [(row["sequence"], row["pipeline"]) for row in rows] == [
        (name, pipeline) for name in (*SCENARIOS, "corrupted") for pipeline in ("rgbdslam", "rtabmap")
    ]
    assert [row["status"] for row in rows] == ["ok"] * 14 + ["failed"] * 2
    assert all(int(row["frames"]) == FRAMES and 0 <= float(row["coverage"]) <= 1 for row in rows[:14])
    assert all(float(row["time_s"]) > 0 for row in rows[:14])
    # The study's flaw in numbers: somewhere a pipeline is charged for time without a pose.
    assert any(
        float(row["coverage"]) < 1
        and row["penalized_ate_rmse"]
        and (not row["ate_rmse"] or float(row["penalized_ate_rmse"]) > float(row["ate_rmse"]))
        for row in rows[:14]
    )
    report = (out / "report.md").read_text()
    assert "- corrupted / rgbdslam: InputError: " in report and "truncated PNG" in report
    assert len([line for line in report.splitlines() if line.startswith("| ")]) == 1 + 16
    assert "## Findings" in report
    for metric in CHARTS:
        assert (out / f"benchmark_{metric}.png").stat().st_size > 0
        assert (out / f"benchmark_{metric}.svg").stat().st_size > 0
    assert json.loads((out / "results.json").read_text())[0]["sequence"] == SCENARIOS[0]
    first = (out / "results.csv").read_text()

    # A re-run serves the fourteen finished tasks from the cache (their timings included).
    assert main(arguments) == 1
    assert (out / "results.csv").read_text().splitlines()[:15] == first.splitlines()[:15]


def test_ray_gives_the_local_results(tmp_path, monkeypatch):
    pytest.importorskip("ray")
    monkeypatch.setitem(base.PIPELINE_MODULES, "fake", MODULE)
    # Ray's workers are fresh interpreters: they find the scripted pipeline's module via PYTHONPATH.
    monkeypatch.setenv("PYTHONPATH", str(Path(__file__).parents[1] / "helpers"))
    tasks = plan_tasks(["360_kidnap"], ["rgbdslam", "rtabmap"], scenario_frames=FRAMES, resolution=(160, 120))
    crash = BenchmarkTask(name="crash", sequence=tasks[0].sequence, pipeline="fake", params=FakeParams(fail="exit"))
    local = run_tasks(tasks, LocalExecutor(jobs=2))
    remote = run_tasks([*tasks, crash], RayExecutor(jobs=2))
    assert [result.status for result in remote] == ["ok", "ok", "failed"]
    assert remote[2].error.startswith("WorkerCrashedError: The worker died unexpectedly")

    def metrics(result):
        return {key: value for key, value in result.report.items() if key != "timing"}

    assert [metrics(result) for result in remote[:2]] == [metrics(result) for result in local]
    assert [(r.frames, r.time_span) for r in remote[:2]] == [(r.frames, r.time_span) for r in local]
