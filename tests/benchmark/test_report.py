"""Benchmark outputs: CSV/JSON columns, charts, markdown table and findings; the CLI around them."""

import csv
import json
from pathlib import Path

import pytest
from benchmark_fake_pipeline import MODULE, FakeParams, write_tum_folder

from viewer_slam.benchmark.benchmark_outputs import findings, write_outputs
from viewer_slam.benchmark.plots import CHARTS
from viewer_slam.benchmark.runner import BenchmarkTask, TaskResult, execute_task
from viewer_slam.benchmark.tables import COLUMNS
from viewer_slam.cli import main
from viewer_slam.pipelines import base

DOCUMENTED_COLUMNS = [
    "sequence",
    "pipeline",
    "ate_rmse",
    "rpe_trans_rmse",
    "rpe_rot_rmse",
    "time_s",
    "fps",
    "coverage",
    "penalized_ate_rmse",
    "frames",
    "frames_with_pose",
    "loop_closures",
    "lost_intervals",
    "status",
]


@pytest.fixture(autouse=True)
def fake_pipelines(monkeypatch, tmp_path):
    for name in ("fake", "steady", "quitter"):
        monkeypatch.setitem(base.PIPELINE_MODULES, name, MODULE)
    monkeypatch.setenv("VIEWSLAM_CACHE", str(tmp_path / "cache"))


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    """Two sequences: steady keeps a pose with a wobble, quitter is exact but gives up (or comes back)."""
    base.PIPELINE_MODULES.update(steady=MODULE, quitter=MODULE)
    folder = write_tum_folder(tmp_path_factory.mktemp("seq") / "tiny", frames=30)
    plan = [
        ("kidnap", "steady", {"wobble_m": 0.05}),
        ("kidnap", "quitter", {"lost_from": 10}),
        ("covered", "steady", {"wobble_m": 0.05}),
        ("covered", "quitter", {"lost_from": 10, "lost_until": 20}),
    ]
    done = [
        execute_task(BenchmarkTask(name=name, sequence=folder, pipeline=pipeline, params=FakeParams(**parameters)))
        for name, pipeline, parameters in plan
    ]
    for name in ("steady", "quitter"):
        del base.PIPELINE_MODULES[name]
    return done + [TaskResult(sequence="broken", pipeline="steady", status="failed", error="ValueError: bad frame")]


@pytest.fixture(scope="module")
def written(results, tmp_path_factory):
    """The output folder of ``results``."""
    out = tmp_path_factory.mktemp("out")
    write_outputs(results, out)
    return out


def test_csv_and_json_have_the_documented_columns(written):
    assert list(COLUMNS) == DOCUMENTED_COLUMNS
    with open(written / "results.csv", newline="") as handle:
        reader = csv.DictReader(handle)
        rows = list(reader)
    assert reader.fieldnames == DOCUMENTED_COLUMNS and len(rows) == 5
    assert [row["status"] for row in rows] == ["ok", "ok", "ok", "ok", "failed"]
    assert rows[4]["ate_rmse"] == "" and rows[4]["sequence"] == "broken"
    assert json.loads(rows[1]["lost_intervals"])[0][1] == pytest.approx(1000.0 + 29 / 30, abs=1e-6)
    assert int(rows[1]["frames_with_pose"]) == 10 and int(rows[1]["frames"]) == 30
    data = json.loads((written / "results.json").read_text())
    assert [list(row) for row in data] == [DOCUMENTED_COLUMNS] * 5
    assert data[0]["ate_rmse"] == pytest.approx(0.05 * 3**0.5, rel=1e-3)  # |(±.05, ±.05, ±.05)| every frame
    assert data[1]["coverage"] == pytest.approx(9 / 29, abs=1e-5)
    assert data[1]["penalized_ate_rmse"] > 10 * data[1]["ate_rmse"]


def test_charts_are_written_as_png_and_svg_reproducibly(results, written, tmp_path):
    write_outputs(results, tmp_path)
    for metric in CHARTS:
        for suffix, signature in ((".png", b"\x89PNG"), (".svg", b"<?xml")):
            first = (written / f"benchmark_{metric}{suffix}").read_bytes()
            assert first.startswith(signature)
            assert first == (tmp_path / f"benchmark_{metric}{suffix}").read_bytes()
    assert len(CHARTS) == 6 and {"ate_rmse", "rpe_trans_rmse", "rpe_rot_rmse", "time_s"} < set(CHARTS)


def test_a_rerun_on_the_same_out_leaves_no_file_of_the_earlier_run_behind(results, tmp_path):
    write_outputs(results, tmp_path)
    (tmp_path / "notes.txt").write_text("mine\n")  # not the benchmark's: stays
    earlier = {path.relative_to(tmp_path) for path in tmp_path.rglob("*") if path.is_file()}
    fewer = [result for result in results if result.sequence != "covered"]
    written = write_outputs(fewer, tmp_path)
    now = {path.relative_to(tmp_path) for path in tmp_path.rglob("*") if path.is_file()}
    assert now == {path.relative_to(tmp_path) for path in written} | {Path("notes.txt")}
    assert {str(path) for path in earlier - now} == {
        "runs/covered.json",
        "runs/covered.steady.txt",
        "runs/covered.quitter.txt",
    }


def test_a_rerun_leaves_no_recording_of_a_pair_it_no_longer_runs(results, tmp_path):
    recordings = tmp_path / "recordings"
    recordings.mkdir()
    for result in results:  # what `benchmark --record` wrote for each row, as `viewslam record` names them
        for suffix in (".rrd", ".json", f".{result.pipeline}.txt"):
            (recordings / f"{result.sequence}.{result.pipeline}{suffix}").write_text("earlier\n")
    (recordings / "notes.md").write_text("mine\n")  # not the benchmark's: stays
    fewer = [result for result in results if result.sequence != "covered"]
    write_outputs(fewer, tmp_path, recorded=True)
    assert not list(recordings.glob("covered.*")) and len(list(recordings.glob("kidnap.*"))) == 6
    write_outputs(fewer, tmp_path)  # no --record: no recording of the earlier run stays
    assert [path.name for path in recordings.iterdir()] == ["notes.md"]


def test_report_has_the_table_failures_and_charts(written):
    report = (written / "report.md").read_text()
    table = [line for line in report.splitlines() if line.startswith("| ")]
    assert table[0].startswith("| Sequence | Pipeline | ATE RMSE [m]") and "Coverage" in table[0]
    assert len(table) == 1 + 5
    assert "| kidnap | quitter | 0.000 |" in report and "| 31.0 % |" in report
    assert "- broken / steady: ValueError: bad frame" in report
    assert all(f"(benchmark_{metric}.png)" in report for metric in CHARTS)


def test_findings_name_losses_recoveries_and_ranking_flips(results):
    text = findings(results)
    assert (
        "**quitter** on *kidnap* lost tracking 1 time (0.7 s of 1.0 s; coverage 31.0 %): "
        "at 0.3 s for 0.7 s [scripted loss], never recovered."
    ) in text
    assert (
        "**quitter** on *covered* lost tracking 1 time (0.4 s of 1.0 s; coverage 62.1 %): "
        "at 0.3 s for 0.4 s [scripted loss], recovered at 0.7 s."
    ) in text
    flips = [line for line in text if line.startswith("On *kidnap*")]
    assert len(flips) == 1 and "classic ATE ranks quitter ahead of steady" in flips[0]
    assert "has a pose for 31.0 % of the time and steady for 100.0 %" in flips[0]
    assert "penalised ATE reverses the order" in flips[0]
    assert not any("steady" in line and "lost tracking" in line for line in text)


def test_findings_without_losses_say_so(results):
    steady_only = [result for result in results if result.pipeline == "steady" and result.ok]
    assert findings(steady_only) == ["No pipeline lost tracking on any sequence."]


def test_cli_runs_writes_outputs_and_reuses_the_cache(tmp_path, capsys):
    folder = write_tum_folder(tmp_path / "tiny", frames=20)
    out = tmp_path / "out"
    arguments = [
        "benchmark",
        str(folder),
        "--pipeline",
        "fake",
        "--out",
        str(out),
        "--jobs",
        "1",
        "--quiet",
        "--param",
        "wobble_m=0.02",
    ]
    assert main(arguments) == 0
    first = (out / "results.csv").read_text()
    assert first.count("\n") == 2 and "\ntiny,fake," in first
    assert main(arguments) == 0
    assert (out / "results.csv").read_text() == first  # served from the cache: even the timing is the same
    assert main([*arguments[:-1], "fail=raise"]) == 1
    assert "tiny,fake," in (out / "results.csv").read_text() and ",failed\n" in (out / "results.csv").read_text()


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--resolution", "64by48"], "--resolution '64by48': expected WIDTHxHEIGHT"),
        (["--pipeline", "orb"], "--pipeline 'fake,orb': valid pipelines are"),
        (["--pipelines", "orb"], "--pipeline 'orb,fake': valid pipelines are"),  # the old spelling, still read
        (["--param", "nonsense=1"], "--param: unknown parameter 'nonsense'"),
        (["--executor", "slurm"], "--executor 'slurm': expected local or ray"),
        (["--ray-address", "auto"], "--ray-address needs --executor ray"),
        (
            ["--seed", str(2**32 - 1), "--trials", "2"],
            "--trials 2 with --seed 4294967295: the last trial's seed 4294967296 is beyond 4294967295",
        ),
    ],
)
def test_cli_bad_options_exit_2_with_one_line(tmp_path, capsys, arguments, message):
    folder = write_tum_folder(tmp_path / "tiny", frames=3)
    assert main(["benchmark", str(folder), "--pipeline", "fake", "--out", str(tmp_path / "o"), *arguments]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and error.startswith("viewslam: error: ") and message in error
