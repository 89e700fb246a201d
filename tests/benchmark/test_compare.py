"""`viewslam benchmark --compare` and `--estimate`: two short benchmark runs of rtabmap on 360_kidnap.

A runs rtabmap with Odom/ResetCountdown=0, B with =5 and an imported estimate beside it
(the scenario's groundtruth with noise and a gap). B's report.md compares the rtabmap row
with A's exactly as `viewslam diff` compares the two runs' reports, and names the estimate
row, which only B has. The estimate's row is checked against `viewslam evaluate` of the
same file.
"""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from viewer_slam.cli import main
from viewer_slam.dataset.sources import open_source
from viewer_slam.dataset.synth.generate import cached_scenario
from viewer_slam.geometry.trajectory import Trajectory, read_tum, write_tum

pytestmark = pytest.mark.slow
FRAMES = 120
BIN = Path(sys.executable).parent
GAP = range(40, 60)  # frames the estimate has no pose for: lost
ARGS = [
    "--scenario-frames",
    str(FRAMES),
    "--resolution",
    "320x240",
    "--pipeline",
    "rtabmap",
    "--param",
    "Rtabmap/DetectionRate=5",
    "--jobs",
    "1",
    "--no-cache",
    "--quiet",
]


@pytest.fixture(scope="module")
def folders(tmp_path_factory):
    """A's and B's results folders, B's stdout, and the estimate file."""
    root = tmp_path_factory.mktemp("compare")
    scenario = cached_scenario("360_kidnap", frames=FRAMES, resolution=(320, 240), seed=0)
    sequence = open_source(scenario)
    posed = [k for k in range(FRAMES) if k not in GAP]
    poses, _ = sequence.groundtruth_at(sequence.timestamps[posed])
    poses[:, :3, 3] += np.random.default_rng(3).normal(0.0, 0.01, (len(posed), 3))
    write_tum(root / "noisy.txt", Trajectory(sequence.timestamps[posed], poses))
    assert main(["benchmark", "360_kidnap", *ARGS, "--param", "Odom/ResetCountdown=0", "--out", str(root / "a")]) == 0
    result = subprocess.run(
        [
            BIN / "viewslam",
            "benchmark",
            "360_kidnap",
            *ARGS,
            "--param",
            "Odom/ResetCountdown=5",
            "--estimate",
            f"noisy={root / 'noisy.txt'}",
            "--out",
            str(root / "b"),
            "--compare",
            str(root / "a"),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 0, result.stderr
    diff = subprocess.run(
        [
            BIN / "viewslam",
            "diff",
            str(root / "a/runs/360_kidnap.json"),
            str(root / "b/runs/360_kidnap.json"),
            "--json",
            str(root / "diff.json"),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert diff.returncode == 0, diff.stderr
    return root, result.stdout, scenario


def section(report: str) -> str:
    return report.split("## Compared with other results", 1)[1].split("## Charts", 1)[0]


def rows(folder: Path) -> dict[str, dict]:
    return {row["pipeline"]: row for row in json.loads((folder / "results.json").read_text())}


def test_the_runs_folder_holds_a_record_report_and_trajectories(folders):
    root, _, _ = folders
    report = json.loads((root / "b/runs/360_kidnap.json").read_text())
    assert list(report["pipelines"]) == ["rtabmap", "noisy"]
    assert report["sequence"]["frames"] == FRAMES
    for name, row in rows(root / "b").items():
        assert len(read_tum(root / f"b/runs/360_kidnap.{name}.txt")) == row["frames_with_pose"] > 0


def test_the_compared_row_has_the_diffs_numbers(folders):
    root, _, _ = folders
    text = section((root / "b/report.md").read_text())
    compared = json.loads((root / "diff.json").read_text())["runs"][0]
    a, b = rows(root / "a")["rtabmap"], rows(root / "b")["rtabmap"]
    assert f"| coverage | {a['coverage']:.3f} | {b['coverage']:.3f} | {b['coverage'] - a['coverage']:+.3f} |" in text
    assert (
        f"| penalised ATE RMSE [m] | {a['penalized_ate_rmse']:.3f} | {b['penalized_ate_rmse']:.3f} | "
        f"{b['penalized_ate_rmse'] - a['penalized_ate_rmse']:+.3f} |"
    ) in text
    only_b = set(np.round(read_tum(root / "b/runs/360_kidnap.rtabmap.txt").timestamps, 6)) - set(
        np.round(read_tum(root / "a/runs/360_kidnap.rtabmap.txt").timestamps, 6)
    )
    assert len(compared["frames_only_b"]) == len(only_b) > 0
    assert f"- frames tracked by B only: {len(only_b)} (" in text
    difference = compared["ate_difference"]
    assert f"over {difference['frames']} frames both tracked: mean {difference['mean']:+.3f} m" in text
    assert "- parameters: Odom/ResetCountdown 0 -> 5" in text


def test_a_row_only_one_folder_has_is_named(folders):
    root, _, _ = folders
    assert "- 360_kidnap / noisy: only in B" in section((root / "b/report.md").read_text())


def test_an_estimate_row_scores_as_evaluate_and_has_no_timing(folders):
    root, stdout, scenario = folders
    row = rows(root / "b")["noisy"]
    assert row["time_s"] is None and row["fps"] is None and row["status"] == "ok"
    assert row["frames"] == FRAMES and row["frames_with_pose"] == FRAMES - len(GAP)
    evaluated = subprocess.run(
        [BIN / "viewslam", "evaluate", str(scenario), str(root / "noisy.txt"), "--json", str(root / "evaluate.json")],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert evaluated.returncode == 0, evaluated.stderr
    expected = json.loads((root / "evaluate.json").read_text())
    assert row["ate_rmse"] == pytest.approx(expected["ate"]["rmse"], abs=1e-12)
    assert row["coverage"] == pytest.approx(expected["coverage"]["ratio"], abs=1e-12)
    assert row["penalized_ate_rmse"] == pytest.approx(expected["penalized_ate"]["rmse"], abs=1e-12)
    assert row["rpe_trans_rmse"] == pytest.approx(expected["rpe"]["trans"]["rmse"], abs=1e-12)
    stamps = open_source(scenario).timestamps
    assert row["lost_intervals"] == [[pytest.approx(stamps[GAP[0] - 1]), pytest.approx(stamps[GAP[-1] + 1])]]
    report = (root / "b/report.md").read_text()
    line = next(line for line in report.splitlines() if line.startswith("| 360_kidnap | noisy |"))
    assert line.split(" | ")[5:7] == ["-", "-"]  # time and FPS
    blocks = json.loads((root / "b/runs/360_kidnap.json").read_text())["pipelines"]
    assert [loss["frame"] for loss in blocks["noisy"]["tracking_lost"]] == [GAP[0]]
    assert blocks["noisy"]["tracking_lost"][0]["cause"]
    assert "noisy lost at" in report


def bad(arguments: list[str], capsys) -> str:
    assert main(["benchmark", *arguments]) == 2
    message = capsys.readouterr().err.strip()
    assert "\n" not in message and "Traceback" not in message
    return message


def test_bad_folders_to_compare_with_are_one_line(folders, tmp_path, capsys):
    root, _, _ = folders
    out = ["--out", str(tmp_path / "out")]
    assert "no such folder" in bad(["360_kidnap", *ARGS, *out, "--compare", str(tmp_path / "nowhere")], capsys)
    assert "no results.json" in bad(["360_kidnap", *ARGS, *out, "--compare", str(tmp_path)], capsys)
    older = tmp_path / "older"
    shutil.copytree(root / "a", older)
    shutil.rmtree(older / "runs")
    message = bad(["360_kidnap", *ARGS, *out, "--compare", str(older)], capsys)
    assert str(older) in message and "older format" in message
    other = tmp_path / "other"
    shutil.copytree(root / "a", other)
    report = json.loads((other / "runs/360_kidnap.json").read_text())
    report["sequence"]["frames"] = FRAMES + 30
    (other / "runs/360_kidnap.json").write_text(json.dumps(report))
    message = bad(["360_kidnap", *ARGS, *out, "--compare", str(other)], capsys)
    assert str(other) in message and "different sequences" in message
    assert not (tmp_path / "out" / "results.json").exists()  # refused before anything ran


def test_an_estimate_needs_exactly_one_sequence_and_a_readable_file(folders, tmp_path, capsys):
    root, _, _ = folders
    estimate = f"noisy={root / 'noisy.txt'}"
    assert "exactly one SEQUENCE" in bad(["360_kidnap", "sitting_static", "--estimate", estimate], capsys)
    (tmp_path / "broken.txt").write_text("not a trajectory\n")
    assert "broken.txt" in bad(
        ["360_kidnap", *ARGS, "--out", str(tmp_path / "out"), "--estimate", f"broken={tmp_path / 'broken.txt'}"], capsys
    )
    assert "already a pipeline's" in bad(["360_kidnap", *ARGS, "--estimate", f"rtabmap={root / 'noisy.txt'}"], capsys)
