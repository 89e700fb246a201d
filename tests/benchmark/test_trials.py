"""`benchmark --trials N`: seeds, one row per trial, medians and min–max, whiskers, the cache per
trial, and comparisons that weigh a difference against the trials' spread (scripted pipeline)."""

import csv
import json
import statistics

import pytest
from matplotlib.container import BarContainer

from viewer_slam.benchmark.cache import ResultCache
from viewer_slam.benchmark.executors import LocalExecutor
from viewer_slam.benchmark.plan import plan_tasks
from viewer_slam.benchmark.plots import draw_metric
from viewer_slam.benchmark.suite import run_benchmark
from viewer_slam.benchmark.tables import TRIAL_COLUMNS
from viewer_slam.benchmark.trials import summarise_pairs
from viewer_slam.cli import main
from viewer_slam.comparison.results import compare_results, load_results
from viewer_slam.schemas import validator

TRIALS = 3
SPREAD = ["--param", "wobble_per_seed_m=0.01"]  # seed s: a wobble of 0.01 * (1 + s) m, so the trials differ


pytestmark = pytest.mark.usefixtures("fake_pipeline")


def benchmark(folder, out, *options) -> int:
    return main(["benchmark", str(folder), "--pipeline", "fake", "--out", str(out), "--quiet", *options])


def test_trial_k_runs_with_seed_plus_k_and_one_trial_is_no_trial(folder):
    tasks = plan_tasks([str(folder)], ["fake"], seed=5, trials=TRIALS)
    assert [(task.trial, task.seed, task.label) for task in tasks] == [
        (k, 5 + k, f"tiny/fake trial {k}") for k in range(TRIALS)
    ]
    [single] = plan_tasks([str(folder)], ["fake"], seed=5)
    assert (single.trial, single.seed, single.label) == (None, 5, "tiny/fake")


def test_every_trial_is_a_row_and_the_table_gives_median_and_min_max(folder, tmp_path, capsys):
    estimate = tmp_path / "estimate.txt"
    estimate.write_text((folder / "groundtruth.txt").read_text())
    out = tmp_path / "out"
    assert (
        benchmark(
            folder,
            out,
            "--trials",
            str(TRIALS),
            "--seed",
            "2",
            "--estimate",
            f"mine={estimate}",
            "--pipeline",
            "fake",
            *SPREAD,
        )
        == 0
    )
    rows = json.loads((out / "results.json").read_text())
    assert [(row["pipeline"], row["trial"], row["seed"]) for row in rows] == [
        ("fake", 0, 2),
        ("fake", 1, 3),
        ("fake", 2, 4),
        ("mine", None, None),
    ]
    with open(out / "results.csv", newline="") as handle:
        assert csv.DictReader(handle).fieldnames == list(TRIAL_COLUMNS)
    ates = [row["ate_rmse"] for row in rows[:TRIALS]]
    assert ates[0] < ates[1] < ates[2]  # a larger seed, a larger wobble

    # The terminal and the report give the median with the min–max beside it; the estimate its one value.
    [fake, mine] = summarise_pairs(rows)
    assert fake["ate_rmse"] == statistics.median(ates) and fake["spread"]["ate_rmse"] == (min(ates), max(ates))
    assert mine["trials"] == 1 and mine["spread"] == {}
    printed = capsys.readouterr().out
    assert f"{ates[1]:.4f} ({ates[0]:.4f}–{ates[2]:.4f})" in printed
    report = (out / "report.md").read_text()
    assert f"| tiny | fake | 3 | {ates[1]:.3f} ({ates[0]:.3f}–{ates[2]:.3f}) |" in report
    assert "| tiny | mine | 1 | 0.000 |" in report
    assert "seeds 2 to 4" in report

    # The run report stands for the pair by its first trial and lists every trial's scores.
    run_report = json.loads((out / "runs" / "tiny.json").read_text())
    assert not list(validator("benchmark_results").iter_errors(rows))
    assert not list(validator("report").iter_errors(run_report))
    block = run_report["pipelines"]["fake"]
    assert block["ate"]["rmse"] == ates[0]
    assert [(trial["trial"], trial["seed"], trial["ate"]["rmse"]) for trial in block["trials"]] == [
        (k, 2 + k, ates[k]) for k in range(TRIALS)
    ]


def test_charts_draw_the_median_with_a_whisker_over_the_trials():
    rows = summarise_pairs(
        [
            {
                "sequence": "s",
                "pipeline": "p",
                "status": "ok",
                "frames": 9,
                "ate_rmse": value,
                **dict.fromkeys(
                    (
                        "rpe_trans_rmse",
                        "rpe_rot_rmse",
                        "time_s",
                        "fps",
                        "coverage",
                        "penalized_ate_rmse",
                        "frames_with_pose",
                        "loop_closures",
                    )
                ),
            }
            for value in (0.1, 0.4, 0.2)
        ]
    )
    figure = draw_metric(rows, "ate_rmse")
    [bars] = [container for container in figure.axes[0].containers if isinstance(container, BarContainer)]
    assert bars.patches[0].get_height() == pytest.approx(0.2)
    [segment] = bars.errorbar.lines[2][0].get_segments()
    assert [y for _, y in segment] == pytest.approx([0.1, 0.4])
    plain = draw_metric([{"sequence": "s", "pipeline": "p", "status": "ok", "ate_rmse": 0.2}], "ate_rmse")
    assert [container.errorbar for container in plain.axes[0].containers] == [None]


def test_a_rerun_with_more_trials_runs_only_the_new_ones(folder, tmp_path):
    cache = ResultCache(tmp_path / "results")
    three = plan_tasks([str(folder)], ["fake"], trials=3)
    first = run_benchmark(three, LocalExecutor(jobs=2), cache, progress=False).results
    assert not any(result.cached for result in first)
    four = run_benchmark(
        plan_tasks([str(folder)], ["fake"], trials=4), LocalExecutor(jobs=2), cache, progress=False
    ).results
    assert [result.cached for result in four] == [True, True, True, False]
    assert [result.report for result in four[:3]] == [result.report for result in first]
    # Trial 1 of seed 0 is trial 0 of seed 1: the same run, served as the trial it is now.
    [shifted] = run_benchmark(
        plan_tasks([str(folder)], ["fake"], seed=1), LocalExecutor(jobs=1), cache, progress=False
    ).results
    assert shifted.cached and (shifted.trial, shifted.seed) == (None, 1) and shifted.report == first[1].report


@pytest.mark.parametrize(("wobble", "beyond"), [("0.015", False), ("0.2", True)])
def test_compare_says_whether_a_difference_exceeds_the_trials_spread(folder, tmp_path, wobble, beyond):
    """A: wobble 0.01, 0.02, 0.03 m; B: 0.015, 0.025, 0.035 m overlaps it, or 0.2 m lies far beyond."""
    a, b = tmp_path / "a", tmp_path / "b"
    assert benchmark(folder, a, "--trials", str(TRIALS), *SPREAD, "--param", "wobble_m=0.01") == 0
    assert (
        benchmark(folder, b, "--trials", str(TRIALS), *SPREAD, "--param", f"wobble_m={wobble}", "--compare", str(a))
        == 0
    )
    [(_, run)] = compare_results(load_results(a), load_results(b)).runs
    ates = {
        side: sorted(row["ate_rmse"] for row in json.loads((where / "results.json").read_text()))
        for side, where in (("a", a), ("b", b))
    }
    assert run.summary["ATE RMSE [m]"] == (ates["a"][1], ates["b"][1])  # the medians
    assert run.spread["ATE RMSE [m]"] == ((ates["a"][0], ates["a"][2]), (ates["b"][0], ates["b"][2]))
    assert run.beyond_spread("ATE RMSE [m]") is beyond
    assert run.spread["coverage"] == ((1.0, 1.0), (1.0, 1.0)) and run.beyond_spread("coverage") is False
    report = (b / "report.md").read_text().split("## Compared with other results")[1]
    assert "| score | A | B | B - A | A min–max | B min–max | beyond spread |" in report
    assert f"| ATE RMSE [m] | {ates['a'][1]:.3f} | {ates['b'][1]:.3f} |" in report
    assert report.split("| ATE RMSE [m] |")[1].split("\n")[0].endswith("yes |" if beyond else "no |")

    # `viewslam diff` of the two run reports says the same.
    assert (
        main(
            [
                "diff",
                str(a / "runs" / "tiny.json"),
                str(b / "runs" / "tiny.json"),
                "--json",
                str(tmp_path / "diff.json"),
            ]
        )
        == 0
    )
    ate = json.loads((tmp_path / "diff.json").read_text())["runs"][0]["summary"]["ATE RMSE [m]"]
    assert (ate["beyond_spread"], ate["a_range"], ate["b_range"]) == (
        beyond,
        [ates["a"][0], ates["a"][2]],
        [ates["b"][0], ates["b"][2]],
    )


def test_one_run_against_trials_is_weighed_against_the_trials_range(folder, tmp_path):
    """Results without trials (as earlier versions wrote them) compare with results with trials."""
    once, trials = tmp_path / "once", tmp_path / "trials"
    assert benchmark(folder, once, "--param", "wobble_m=0.5") == 0
    assert "trial" not in json.loads((once / "results.json").read_text())[0]
    assert benchmark(folder, trials, "--trials", str(TRIALS), *SPREAD, "--compare", str(once)) == 0
    [(_, run)] = compare_results(load_results(once), load_results(trials)).runs
    assert run.spread["ATE RMSE [m]"][0] is None and run.beyond_spread("ATE RMSE [m]") is True
    [(_, alone)] = compare_results(load_results(once), load_results(once)).runs
    assert alone.spread == {} and alone.beyond_spread("ATE RMSE [m]") is None  # one run each: no spread to weigh
    assert "A one run; B the median of 3 trials (frame by frame: trial 0, seed 0)" in (trials / "report.md").read_text()
