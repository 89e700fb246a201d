"""`viewslam diff` on two runs of the scripted pipeline, whose poses and losses are known exactly."""

import json

import numpy as np
import pytest
from benchmark_fake_pipeline import MODULE, write_tum_folder

from viewer_slam.cli import main
from viewer_slam.comparison import compare_reports
from viewer_slam.comparison.output import frame_ranges
from viewer_slam.pipelines import base

FRAMES = 30


@pytest.fixture
def reports(tmp_path, monkeypatch):
    """A: exact poses, lost from frame 10 for good. B: wobbling poses, lost over frames 15 to 19."""
    monkeypatch.setitem(base.PIPELINE_MODULES, "fake", MODULE)
    monkeypatch.setenv("VIEWSLAM_CACHE", str(tmp_path / "cache"))
    folder = write_tum_folder(tmp_path / "tiny", frames=FRAMES)
    for name, params in (("a", ["lost_from=10"]), ("b", ["lost_from=15", "lost_until=20", "wobble_m=0.05"])):
        arguments = [argument for value in params for argument in ("--param", value)]
        assert (
            main(
                [
                    "record",
                    str(folder),
                    "--pipeline",
                    "fake",
                    *arguments,
                    "--out",
                    str(tmp_path / f"{name}.rrd"),
                    "--quiet",
                ]
            )
            == 0
        )
    return tmp_path / "a.json", tmp_path / "b.json"


def test_frames_losses_and_parameters_are_those_scripted(reports):
    (run,) = compare_reports(*reports).runs
    assert run.frames_only_b.tolist() == [*range(10, 15), *range(20, FRAMES)]
    assert run.frames_only_a.tolist() == []
    assert [(loss["frame"], loss["other_tracking"]) for loss in run.losses_vanished] == [(10, True)]
    assert [(loss["frame"], loss["other_tracking"]) for loss in run.losses_appeared] == [(15, False)]
    assert run.parameters == {"wobble_m": (0.0, 0.05), "lost_from": (10, 15), "lost_until": (-1, 20)}


def test_per_frame_errors_and_their_difference(reports):
    (run,) = compare_reports(*reports).runs
    tracked_a = np.isfinite(run.ate_a)
    assert np.flatnonzero(tracked_a).tolist() == list(range(10))
    np.testing.assert_allclose(run.ate_a[tracked_a], 0.0, atol=1e-5)  # exact up to a constant offset
    both = np.isfinite(run.ate_difference)
    assert np.flatnonzero(both).tolist() == list(range(10))
    np.testing.assert_allclose(run.ate_difference[both], run.ate_b[both] - run.ate_a[both])
    assert np.all(run.ate_b[both] > 0.05)  # the wobble is not aligned away


def test_the_table_and_json_agree_with_the_comparison(reports, tmp_path, capsys):
    out = tmp_path / "diff.json"
    assert main(["diff", *map(str, reports), "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    data = json.loads(out.read_text())["runs"][0]
    assert data["frames_only_b"] == [*range(10, 15), *range(20, FRAMES)]
    assert "frames tracked by B only: 15 (10-14, 20-29)" in printed
    assert "lost_from 10 -> 15" in printed
    assert data["summary"]["poses"] == {"a": 10, "b": 25, "difference": 15}


def test_frame_ranges_join_consecutive_frames():
    assert frame_ranges(np.array([3, 4, 5, 9, 11, 12])) == "3-5, 9, 11-12"
    assert frame_ranges(np.array([], dtype=int)) == "none"


def test_an_out_path_without_the_rrd_extension_is_refused(reports, tmp_path, capsys):
    assert main(["diff", *map(str, reports), "--out", str(tmp_path / "diff.png")]) == 2
    assert "the recording must have the .rrd extension" in capsys.readouterr().err


def test_two_methods_of_one_report_are_compared_by_name(tmp_path, monkeypatch, capsys):
    """A pipeline against an estimate file in one recording (the file: the same pipeline's
    trajectory, lost from frame 10): --runs names the pair."""
    monkeypatch.setitem(base.PIPELINE_MODULES, "fake", MODULE)
    monkeypatch.setenv("VIEWSLAM_CACHE", str(tmp_path / "cache"))
    folder = write_tum_folder(tmp_path / "tiny", frames=FRAMES)
    assert (
        main(
            [
                "record",
                str(folder),
                "--pipeline",
                "fake",
                "--param",
                "lost_from=10",
                "--out",
                str(tmp_path / "early.rrd"),
                "--quiet",
            ]
        )
        == 0
    )
    assert (
        main(
            [
                "record",
                str(folder),
                "--pipeline",
                "fake",
                "--estimate",
                f"early={tmp_path / 'early.fake.txt'}",
                "--out",
                str(tmp_path / "both.rrd"),
                "--quiet",
            ]
        )
        == 0
    )
    capsys.readouterr()
    report, out = tmp_path / "both.json", tmp_path / "diff.json"
    assert main(["diff", str(report), str(report), "--runs", "fake:early", "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    (run,) = json.loads(out.read_text())["runs"]
    assert (run["a"], run["b"]) == ("fake", "early")
    assert run["frames_only_a"] == list(range(10, FRAMES)) and run["frames_only_b"] == []
    assert run["parameters"] is None and "parameters: not compared" in printed
    # The replayed file has no rate or loop closures of its own: no number to subtract.
    assert run["summary"]["frames/s"]["b"] is None and run["summary"]["frames/s"]["difference"] is None
    assert run["summary"]["poses"] == {"a": FRAMES, "b": 10, "difference": 10 - FRAMES}


@pytest.mark.parametrize("runs, problem", [("fake", "expected A_RUN:B_RUN"), ("fake:nothing", "has no run 'nothing'")])
def test_a_bad_run_pair_is_one_line(reports, runs, problem, capsys):
    assert main(["diff", *map(str, reports), "--runs", runs]) == 2
    error = capsys.readouterr().err
    assert problem in error and error.count("\n") == 1
