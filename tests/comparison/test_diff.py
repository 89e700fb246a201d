"""`viewslam diff`: rtabmap on a short 360_kidnap with Odom/ResetCountdown=0 (A) against =5 (B).

The comparison's numbers are checked against what the two reports and their trajectory
files say on their own.
"""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rerun.chunk import RrdReader

from viewer_slam.cli import main
from viewer_slam.dataset.synth.generate import cached_scenario
from viewer_slam.geometry.trajectory import read_tum

pytestmark = pytest.mark.slow
FRAMES = 120
BIN = Path(sys.executable).parent


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The reports of A (no reset) and B (reset after 5 lost frames), and the diff's JSON and stdout."""
    folder = tmp_path_factory.mktemp("runs")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("VIEWSLAM_CACHE", str(tmp_path_factory.mktemp("cache")))
        scenario = cached_scenario("360_kidnap", frames=FRAMES, resolution=(320, 240), seed=0)
        for name, countdown in (("a", 0), ("b", 5)):
            assert (
                main(
                    [
                        "record",
                        str(scenario),
                        "--pipeline",
                        "rtabmap",
                        "--param",
                        "Rtabmap/DetectionRate=5",
                        "--param",
                        f"Odom/ResetCountdown={countdown}",
                        "--out",
                        str(folder / f"{name}.rrd"),
                        "--quiet",
                    ]
                )
                == 0
            )
    return folder


@pytest.fixture(scope="module")
def compared(runs):
    result = subprocess.run(
        [
            BIN / "viewslam",
            "diff",
            str(runs / "a.json"),
            str(runs / "b.json"),
            "--json",
            str(runs / "diff.json"),
            "--out",
            str(runs / "diff.rrd"),
        ],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stderr
    return json.loads((runs / "diff.json").read_text())["runs"][0], result.stdout


def report(runs: Path, name: str) -> dict:
    return json.loads((runs / f"{name}.json").read_text())["pipelines"]["rtabmap"]


def test_the_frames_recovered_are_those_only_the_resetting_run_has_a_pose_for(runs, compared):
    comparison, stdout = compared
    a_stamps = set(np.round(read_tum(runs / "a.rtabmap.txt").timestamps, 6))
    b_stamps = set(np.round(read_tum(runs / "b.rtabmap.txt").timestamps, 6))
    assert len(comparison["frames_only_b"]) == len(b_stamps - a_stamps) > 0
    assert len(comparison["frames_only_a"]) == len(a_stamps - b_stamps)
    a, b = report(runs, "a"), report(runs, "b")
    assert (
        len(comparison["frames_only_b"]) - len(comparison["frames_only_a"])
        == b["frames_with_pose"] - a["frames_with_pose"]
        == comparison["summary"]["poses"]["difference"]
    )
    assert f"frames tracked by B only: {len(comparison['frames_only_b'])} (" in stdout


def test_coverage_and_penalised_ate_change_as_the_reports_say(runs, compared):
    comparison, stdout = compared
    a, b = report(runs, "a"), report(runs, "b")
    coverage = comparison["summary"]["coverage"]
    assert coverage["difference"] == pytest.approx(b["coverage"]["ratio"] - a["coverage"]["ratio"])
    assert coverage["difference"] > 0  # resetting keeps a pose for longer
    penalised = comparison["summary"]["penalised ATE RMSE [m]"]
    assert penalised["difference"] == pytest.approx(b["penalized_ate"]["rmse"] - a["penalized_ate"]["rmse"])
    assert f"{coverage['difference']:+.3f}" in stdout and f"{penalised['difference']:+.3f}" in stdout


def test_the_per_frame_errors_are_the_reports_ate_again(runs, compared):
    comparison, _ = compared
    for side in ("a", "b"):
        errors = np.array([e for e in comparison["per_frame"][f"ate_{side}"] if e is not None])
        expected = report(runs, side)["ate"]
        assert len(errors) == expected["n"]
        assert np.sqrt(np.mean(errors**2)) == pytest.approx(expected["rmse"], abs=1e-5)
    both = [
        (a, b)
        for a, b in zip(comparison["per_frame"]["ate_a"], comparison["per_frame"]["ate_b"])
        if a is not None and b is not None
    ]
    assert comparison["ate_difference"]["frames"] == len(both)
    assert comparison["ate_difference"]["mean"] == pytest.approx(np.mean([b - a for a, b in both]))


def test_losses_that_appear_or_vanish_and_the_parameters_that_differ(runs, compared):
    comparison, _ = compared
    a_frames = {loss["frame"] for loss in report(runs, "a")["tracking_lost"]}
    b_frames = {loss["frame"] for loss in report(runs, "b")["tracking_lost"]}
    assert {loss["frame"] for loss in comparison["losses_appeared"]} == b_frames - a_frames
    assert {loss["frame"] for loss in comparison["losses_vanished"]} == a_frames - b_frames
    assert comparison["parameters"] == {"Odom/ResetCountdown": {"a": 0, "b": 5}}


def test_the_diff_recording_holds_both_runs_and_the_difference_without_empty_chunks(runs, compared):
    recording = runs / "diff.rrd"
    assert subprocess.run([BIN / "rerun", "rrd", "verify", str(recording)], capture_output=True).returncode == 0
    chunks = list(RrdReader(recording).stream().to_chunks())
    assert all(chunk.num_rows > 0 for chunk in chunks)
    entities = {chunk.entity_path for chunk in chunks}
    assert {
        "/world/groundtruth",
        "/world/A/rtabmap/trajectory",
        "/world/B/rtabmap/trajectory",
        "/metrics/A/rtabmap/ate",
        "/metrics/B/rtabmap/ate",
        "/metrics/difference/rtabmap/ate",
        "/metrics/A/rtabmap/pose",
        "/metrics/B/rtabmap/pose",
    } <= entities
    difference_rows = sum(
        chunk.num_rows
        for chunk in chunks
        if chunk.entity_path == "/metrics/difference/rtabmap/ate" and not chunk.is_static
    )
    both = compared[0]["ate_difference"]["frames"]
    assert both <= difference_rows <= both + 2  # the values, and a break after each run of them


def bad(arguments: list[str], capsys) -> str:
    assert main(["diff", *arguments]) == 2
    message = capsys.readouterr().err.strip()
    assert "\n" not in message and "Traceback" not in message
    return message


def copy_report(runs: Path, tmp_path: Path, edit=None, keep_trajectory: bool = True) -> Path:
    target = tmp_path / "copy.json"
    data = json.loads((runs / "b.json").read_text())
    if edit:
        edit(data)
    target.write_text(json.dumps(data))
    if keep_trajectory:
        shutil.copy(runs / "b.rtabmap.txt", tmp_path / "copy.rtabmap.txt")
    return target


def test_reports_of_different_sequences_are_refused(runs, tmp_path, capsys):
    other = copy_report(runs, tmp_path, lambda data: data["sequence"].update(name="fr1/desk"))
    assert "different sequences" in bad([str(runs / "a.json"), str(other)], capsys)


def test_a_missing_trajectory_is_named(runs, tmp_path, capsys):
    lonely = copy_report(runs, tmp_path, keep_trajectory=False)
    assert "copy.rtabmap.txt" in bad([str(runs / "a.json"), str(lonely)], capsys)


def test_a_report_of_an_older_format_is_refused(runs, tmp_path, capsys):
    older = copy_report(runs, tmp_path, lambda data: data["pipelines"]["rtabmap"].pop("penalized_ate"))
    assert "older or unknown format" in bad([str(older), str(runs / "b.json")], capsys)
    evaluate_output = tmp_path / "evaluate.json"
    evaluate_output.write_text(json.dumps({"ate": {"rmse": 0.1}}))
    assert "not a `viewslam record` report" in bad([str(evaluate_output), str(runs / "b.json")], capsys)
