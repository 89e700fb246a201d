"""`viewslam evaluate` end to end, and every kind of bad input through the command line."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from fixtures_eval import TRAJECTORIES, TUM_RPY

from viewer_slam.cli import main
from viewer_slam.evaluation import evaluate
from viewer_slam.geometry.trajectory import read_tum

GROUNDTRUTH = TRAJECTORIES / "freiburg1_xyz-groundtruth.txt"
ESTIMATE = TRAJECTORIES / "freiburg1_xyz-rgbdslam.txt"
VIEWSLAM = Path(sys.executable).parent / "viewslam"
GOOD_LINES = "1.0 0 0 0 0 0 0 1\n1.1 0.1 0 0 0 0 0 1\n"


def run(capsys, *args) -> tuple[int, str, str]:
    code = main(["evaluate", *map(str, args)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_prints_the_table_and_writes_json_and_plot(capsys, tmp_path):
    code, out, err = run(capsys, GROUNDTRUTH, ESTIMATE, "--json", tmp_path / "e.json", "--plot", tmp_path / "e.png",
                         "--delta", 1, "--delta-unit", "frames")
    assert code == 0 and err == ""
    for row in ("ATE [m]", "RPE trans [m]", "RPE rot [deg]", "penalised ATE [m]", "786 associated pairs"):
        assert row in out
    blocks = json.loads((tmp_path / "e.json").read_text())
    expected = evaluate(read_tum(GROUNDTRUTH), read_tum(ESTIMATE), delta=1, delta_unit="frames").to_dict()
    assert blocks == json.loads(json.dumps(expected))
    assert set(blocks) == {"ate", "rpe", "coverage", "penalized_ate"}
    assert set(blocks["rpe"]) == {"trans", "rot", "delta", "delta_unit"}
    assert set(blocks["ate"]) == {"rmse", "mean", "median", "std", "min", "max", "n"}
    assert (blocks["rpe"]["delta"], blocks["rpe"]["delta_unit"]) == (1, "frames")
    assert (tmp_path / "e.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (tmp_path / "e.png").stat().st_size > 20_000


def test_output_is_byte_identical_across_runs(capsys, tmp_path):
    for name in ("a", "b"):
        assert run(capsys, GROUNDTRUTH, ESTIMATE, "--all-deltas", "--json", tmp_path / f"{name}.json",
                   "--plot", tmp_path / f"{name}.png")[0] == 0
    assert (tmp_path / "a.json").read_bytes() == (tmp_path / "b.json").read_bytes()
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "b.png").read_bytes()


def test_scale_option_aligns_a_monocular_estimate(capsys, tmp_path):
    groundtruth, monocular = TRAJECTORIES / "fr2_desk_groundtruth.txt", TRAJECTORIES / "fr2_desk_ORB_kf_mono.txt"
    assert run(capsys, groundtruth, monocular, "--json", tmp_path / "rigid.json")[0] == 0
    assert run(capsys, groundtruth, monocular, "--scale", "--json", tmp_path / "scaled.json")[0] == 0
    rigid = json.loads((tmp_path / "rigid.json").read_text())["ate"]["rmse"]
    scaled = json.loads((tmp_path / "scaled.json").read_text())["ate"]["rmse"]
    assert scaled < 0.02 and rigid > 0.5  # an arbitrary-scale map only fits after scaling


def test_a_sequence_folder_as_groundtruth_measures_coverage_over_its_frames(capsys, tmp_path):
    sequence = tmp_path / "rgbd_dataset_freiburg1_rpy"
    shutil.copytree(TUM_RPY, sequence, ignore=shutil.ignore_patterns("*.png"))
    groundtruth = read_tum(sequence / "groundtruth.txt")
    (tmp_path / "est.txt").write_text((sequence / "groundtruth.txt").read_text())
    assert run(capsys, sequence, tmp_path / "est.txt", "--json", tmp_path / "folder.json")[0] == 0
    assert run(capsys, sequence / "groundtruth.txt", tmp_path / "est.txt", "--json", tmp_path / "file.json")[0] == 0
    assert json.loads((tmp_path / "folder.json").read_text())["coverage"] == {"ratio": 1.0, "lost_intervals": []}
    assert json.loads((tmp_path / "file.json").read_text())["ate"]["n"] == len(groundtruth)


def bad_trajectory(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "estimate.txt"
    path.write_text(text)
    return path


BAD_ESTIMATES = {
    "missing file": (None, "no such file"),
    "seven fields": ("# header\n1.0 0 0 0 0 0 1\n", ":2: expected 8 fields"),
    "nan": ("1.0 0 0 0 0 0 0 1\n1.1 nan 0 0 0 0 0 1\n", ":2: a field is NaN or infinite"),
    "zero quaternion": (GOOD_LINES + "1.2 0 0 0 0 0 0 0\n", ":3: zero quaternion"),
    "no overlap": (GOOD_LINES, ": no temporal overlap with the groundtruth"),
}


@pytest.mark.parametrize("case", BAD_ESTIMATES)
def test_a_bad_estimate_is_one_line_naming_the_file(capsys, tmp_path, case):
    text, problem = BAD_ESTIMATES[case]
    path = tmp_path / "absent.txt" if text is None else bad_trajectory(tmp_path, text)
    code, out, err = run(capsys, GROUNDTRUTH, path)
    assert code == 2 and out == ""
    assert err.splitlines() == [err.strip()]
    assert err.startswith(f"viewslam: error: {path}") and problem in err


def test_a_folder_that_is_not_a_sequence_is_one_line(capsys, tmp_path):
    (tmp_path / "notes.txt").write_text("hello\n")
    code, _, err = run(capsys, tmp_path, ESTIMATE)
    assert code == 2
    assert err == f"viewslam: error: {tmp_path}: not a TUM RGB-D sequence (no rgb.txt)\n"


def test_bad_options_exit_2(capsys):
    assert run(capsys, GROUNDTRUTH, ESTIMATE, "--delta", "1.5", "--delta-unit", "frames")[0] == 2
    assert run(capsys, GROUNDTRUTH, ESTIMATE, "--max-difference", "0")[0] == 2
    code, _, err = run(capsys, GROUNDTRUTH, ESTIMATE, "--delta-unit", "metres")
    assert code == 2 and len(err.strip().splitlines()) == 1


def test_the_installed_command_reports_bad_input_without_a_traceback(tmp_path):
    path = bad_trajectory(tmp_path, "1.0 0 0 0 0 0 1\n")
    result = subprocess.run([VIEWSLAM, "evaluate", GROUNDTRUTH, path], capture_output=True, text=True, timeout=120)
    assert result.returncode == 2
    assert result.stderr == f"viewslam: error: {path}:1: expected 8 fields (timestamp tx ty tz qx qy qz qw), found 7\n"


def test_an_unreadable_png_in_a_sequence_is_one_line_naming_it(tmp_path):
    """Frames are read by `record`; a broken first image must stop it with one line, not a traceback."""
    sequence = tmp_path / "rgbd_dataset_freiburg1_rpy"
    shutil.copytree(TUM_RPY, sequence, ignore=shutil.ignore_patterns("*.png"))
    first_listed = next(line for line in (sequence / "rgb.txt").read_text().splitlines() if not line.startswith("#"))
    broken = sequence / first_listed.split()[1]
    broken.write_bytes(b"this is not a PNG")
    result = subprocess.run([VIEWSLAM, "record", sequence, "--pipeline", "rgbdslam", "--max-frames", "2",
                             "--quiet", "--out", tmp_path / "x.rrd"], capture_output=True, text=True, timeout=300)
    assert result.returncode == 2
    assert result.stderr == f"viewslam: error: {broken}: not a readable image\n"
