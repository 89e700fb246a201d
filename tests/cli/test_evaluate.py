"""`viewslam evaluate` end to end, and every kind of bad input through the command line."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from fixtures_eval import TRAJECTORIES, TUM_RPY, perturbed
from trajectory_writers import write_euroc, write_kitti

from viewer_slam.cli import main
from viewer_slam.dataset.sources import open_source
from viewer_slam.evaluation import evaluate
from viewer_slam.geometry.trajectory import Trajectory, read_tum, write_tum

GROUNDTRUTH = TRAJECTORIES / "freiburg1_xyz-groundtruth.txt"
ESTIMATE = TRAJECTORIES / "freiburg1_xyz-rgbdslam.txt"
VIEWSLAM = Path(sys.executable).parent / "viewslam"
GOOD_LINES = "1.0 0 0 0 0 0 0 1\n1.1 0.1 0 0 0 0 0 1\n"


def run(capsys, *args) -> tuple[int, str, str]:
    code = main(["evaluate", *map(str, args)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_prints_the_table_and_writes_json_and_plot(capsys, tmp_path):
    code, out, err = run(
        capsys,
        GROUNDTRUTH,
        ESTIMATE,
        "--json",
        tmp_path / "e.json",
        "--plot",
        tmp_path / "e.png",
        "--delta",
        1,
        "--delta-unit",
        "frames",
    )
    assert code == 0
    assert err == f"wrote {tmp_path / 'e.json'}\nwrote {tmp_path / 'e.png'}\n"
    for column in ("estimate", "pairs", "coverage", "ATE", "ATE seg.", "RPE trans", "RPE rot", "penal. ATE"):
        assert column in out
    blocks = json.loads((tmp_path / "e.json").read_text())
    expected = evaluate(read_tum(GROUNDTRUTH), read_tum(ESTIMATE), delta=1, delta_unit="frames").to_dict()
    assert blocks == json.loads(json.dumps(expected))
    assert set(blocks) == {"alignment", "ate", "ate_segments", "rpe", "coverage", "penalized_ate"}
    assert set(blocks["rpe"]) == {"trans", "rot", "delta", "delta_unit", "mode"}
    assert set(blocks["ate"]) == set(blocks["ate_segments"]) == {"rmse", "mean", "median", "std", "min", "max", "n"}
    assert (blocks["rpe"]["delta"], blocks["rpe"]["delta_unit"]) == (1, "frames")
    assert blocks["alignment"] == "rigid"
    assert table_rows(out)[str(ESTIMATE)] == [
        "786",
        f"{blocks['coverage']['ratio']:.1%}",
        *(f"{blocks[key]['rmse']:.4f}" for key in ("ate", "ate_segments")),
        *(f"{blocks['rpe'][key]['rmse']:.4f}" for key in ("trans", "rot")),
        f"{blocks['penalized_ate']['rmse']:.4f}",
    ]
    assert "RPE trans [m], rot [deg]: alignment-free, Δ = 1 frame" in out
    assert (tmp_path / "e.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (tmp_path / "e.png").stat().st_size > 20_000


def table_rows(out: str) -> dict[str, list[str]]:
    """The table's cells by estimate (the first cell of a row that names a trajectory file)."""
    rows = {}
    for line in out.splitlines():
        cells = line.split()
        if cells and cells[0].endswith(".txt") and not cells[0].endswith(":"):
            rows[cells[0]] = cells[1:]
    return rows


@pytest.mark.parametrize("picture", ["png", "svg", "pdf"])
def test_output_is_byte_identical_across_runs(capsys, tmp_path, monkeypatch, picture):
    for name, second in (("a", 1_700_000_000.0), ("b", 1_700_000_100.0)):  # a date in the file would differ
        monkeypatch.setattr("time.time", lambda second=second: second)
        assert (
            run(
                capsys,
                GROUNDTRUTH,
                ESTIMATE,
                "--all-deltas",
                "--json",
                tmp_path / f"{name}.json",
                "--plot",
                tmp_path / f"{name}.{picture}",
            )[0]
            == 0
        )
    assert (tmp_path / "a.json").read_bytes() == (tmp_path / "b.json").read_bytes()
    assert (tmp_path / f"a.{picture}").read_bytes() == (tmp_path / f"b.{picture}").read_bytes()


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
    frames = open_source(sequence).timestamps
    assert json.loads((tmp_path / "folder.json").read_text())["coverage"] == {
        "ratio": 1.0,
        "lost_intervals": [],
        "span": {"start": frames[0], "end": frames[-1], "rule": "sequence frames"},
    }
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
    result = subprocess.run(
        [
            VIEWSLAM,
            "record",
            sequence,
            "--pipeline",
            "rgbdslam",
            "--max-frames",
            "2",
            "--quiet",
            "--out",
            tmp_path / "x.rrd",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 2
    assert result.stderr == f"viewslam: error: {broken}: not a readable image\n"


README_CUT = "freiburg1_xyz-rgbdslam_first_half.txt"


def first_half(tmp_path: Path) -> Path:
    """The README estimate cut at its middle: a method that quits halfway."""
    estimate = read_tum(ESTIMATE)
    middle = (estimate.timestamps[0] + estimate.timestamps[-1]) / 2
    path = tmp_path / README_CUT
    write_tum(path, estimate.subset(estimate.timestamps <= middle))
    return path


def test_the_readme_example_is_fully_covered_and_its_first_half_half_covered(capsys, tmp_path):
    cut = first_half(tmp_path)
    code, out, _ = run(capsys, GROUNDTRUTH, ESTIMATE, cut, "--json", tmp_path / "e.json")
    assert code == 0
    blocks = json.loads((tmp_path / "e.json").read_text())["estimates"]
    full, half = blocks[str(ESTIMATE)]["coverage"], blocks[str(cut)]["coverage"]
    assert full["ratio"] >= 0.99 and full["lost_intervals"] == []
    assert 0.45 <= half["ratio"] <= 0.55 and len(half["lost_intervals"]) == 1
    start = read_tum(ESTIMATE).timestamps[0]
    assert full["span"] == {
        "start": start,
        "end": read_tum(GROUNDTRUTH).timestamps[-1],
        "rule": "estimate start to groundtruth end",
    }
    assert f"{ESTIMATE}: read as TUM; coverage over {start:.6f}.." in out
    assert "estimate start to groundtruth end), 0 lost intervals" in out
    assert f"{cut}: read as TUM; coverage over" in out and out.rstrip().endswith(", 1 lost interval")


def test_span_and_sequence_options_set_the_coverage_span(capsys, tmp_path):
    groundtruth = read_tum(GROUNDTRUTH)
    start, end = groundtruth.timestamps[0], groundtruth.timestamps[-1]
    assert run(capsys, GROUNDTRUTH, ESTIMATE, "--span", f"{start},{end}", "--json", tmp_path / "s.json")[0] == 0
    coverage = json.loads((tmp_path / "s.json").read_text())["coverage"]
    assert coverage["span"] == {"start": start, "end": end, "rule": "--span"}
    assert coverage["ratio"] < 0.9  # the 3.5 s of motion capture before the camera now count as lost

    sequence = tmp_path / "rgbd_dataset_freiburg1_rpy"
    shutil.copytree(TUM_RPY, sequence, ignore=shutil.ignore_patterns("*.png"))
    (tmp_path / "est.txt").write_text((sequence / "groundtruth.txt").read_text())
    assert (
        run(
            capsys,
            sequence / "groundtruth.txt",
            tmp_path / "est.txt",
            "--sequence",
            sequence,
            "--json",
            tmp_path / "q.json",
        )[0]
        == 0
    )
    frames = open_source(sequence).timestamps
    assert json.loads((tmp_path / "q.json").read_text())["coverage"]["span"] == {
        "start": frames[0],
        "end": frames[-1],
        "rule": "sequence frames",
    }


def test_several_estimates_give_the_same_numbers_per_row_as_separate_calls(capsys, tmp_path):
    estimates = [ESTIMATE, TRAJECTORIES / "freiburg1_xyz-rgbdslam_drift_short.txt", first_half(tmp_path)]
    code, together, _ = run(capsys, GROUNDTRUTH, *estimates, "--json", tmp_path / "all.json", "--align", "origin")
    assert code == 0
    report = json.loads((tmp_path / "all.json").read_text())
    assert report["groundtruth"] == str(GROUNDTRUTH) and list(report["estimates"]) == list(map(str, estimates))
    rows = table_rows(together)
    assert list(rows) == list(map(str, estimates))
    for number, estimate in enumerate(estimates):
        code, alone, _ = run(capsys, GROUNDTRUTH, estimate, "--json", tmp_path / f"{number}.json", "--align", "origin")
        assert code == 0
        assert table_rows(alone) == {str(estimate): rows[str(estimate)]}
        assert json.loads((tmp_path / f"{number}.json").read_text()) == report["estimates"][str(estimate)]
    assert len({tuple(cells) for cells in rows.values()}) == 3  # three different estimates, three different rows


def test_a_plot_of_several_estimates(capsys, tmp_path):
    code, _, err = run(capsys, GROUNDTRUTH, ESTIMATE, first_half(tmp_path), "--plot", tmp_path / "both.svg")
    assert code == 0 and err == f"wrote {tmp_path / 'both.svg'}\n"
    picture = (tmp_path / "both.svg").read_text()
    assert picture.count(Path(ESTIMATE).name) == 1 and picture.count(README_CUT) == 1  # one legend entry each


@pytest.mark.parametrize("align", ["rigid", "sim3", "origin", "segments", "none"])
def test_each_alignment_is_named_in_the_report_and_on_the_terminal(capsys, tmp_path, align):
    code, out, _ = run(capsys, GROUNDTRUTH, ESTIMATE, "--align", align, "--json", tmp_path / "a.json")
    assert code == 0
    blocks = json.loads((tmp_path / "a.json").read_text())
    assert blocks["alignment"] == align
    expected = evaluate(read_tum(GROUNDTRUTH), read_tum(ESTIMATE), align=align).to_dict()
    assert blocks == json.loads(json.dumps(expected))
    legend = out.splitlines()[1:4]
    assert legend[0].startswith("  ATE, penal. ATE [m]: ") and legend[1].startswith("  ATE seg. [m]: ")
    assert legend[2].startswith("  RPE trans [m], rot [deg]: alignment-free")
    assert {
        "rigid": "rigid alignment",
        "sim3": "similarity",
        "origin": "origin alignment",
        "segments": "each tracked segment",
        "none": "no alignment",
    }[align] in legend[0]


def test_scale_is_the_sim3_spelling(capsys, tmp_path):
    assert run(capsys, GROUNDTRUTH, ESTIMATE, "--scale", "--json", tmp_path / "a.json")[0] == 0
    assert run(capsys, GROUNDTRUTH, ESTIMATE, "--align", "sim3", "--json", tmp_path / "b.json")[0] == 0
    assert (tmp_path / "a.json").read_text() == (tmp_path / "b.json").read_text()


BAD_OPTIONS = {
    "delta inf": (["--delta", "inf"], "'--delta'"),
    "delta nan": (["--delta", "nan"], "'--delta'"),
    "delta overflow": (["--delta", "1e400"], "'--delta'"),
    "offset nan": (["--offset", "nan"], "'--offset'"),
    "offset inf": (["--offset", "-inf"], "'--offset'"),
    "max difference nan": (["--max-difference", "nan"], "'--max-difference'"),
    "max difference zero": (["--max-difference", "0"], "'--max-difference'"),
    "plot extension": (["--plot", "p.xyz"], "--plot p.xyz: unsupported file extension '.xyz'"),
    "plot without extension": (["--plot", "picture"], "--plot picture: no file extension"),
    "span one number": (["--span", "5"], "'--span'"),
    "span reversed": (["--span", "9,5"], "'--span'"),
    "span nan": (["--span", "nan,5"], "'--span'"),
    "scale with origin": (["--scale", "--align", "origin"], "--scale means --align sim3"),
    "frames not whole": (["--delta", "1.5", "--delta-unit", "frames"], "--delta: a delta in frames"),
    "unknown alignment": (["--align", "affine"], "'--align'"),
}


@pytest.mark.parametrize("case", BAD_OPTIONS)
def test_a_bad_option_is_one_line_naming_it(capsys, tmp_path, case):
    options, named = BAD_OPTIONS[case]
    code, out, err = run(capsys, GROUNDTRUTH, ESTIMATE, *options, "--json", tmp_path / "e.json")
    assert code == 2 and out == ""
    assert err.splitlines() == [err.strip()] and named in err
    assert "Traceback" not in err and not (tmp_path / "e.json").exists()


def test_an_estimate_given_twice_is_refused(capsys):
    code, out, err = run(capsys, GROUNDTRUTH, ESTIMATE, ESTIMATE)
    assert (code, out, err) == (2, "", f"viewslam: error: {ESTIMATE}: given twice as an estimate\n")


def test_a_second_estimate_without_overlap_stops_before_anything_is_written(capsys, tmp_path):
    late = bad_trajectory(tmp_path, GOOD_LINES)
    code, out, err = run(capsys, GROUNDTRUTH, ESTIMATE, late, "--json", tmp_path / "e.json")
    assert code == 2 and out == "" and not (tmp_path / "e.json").exists()
    assert err.startswith(f"viewslam: error: {late}: no temporal overlap with the groundtruth (estimate 1.000..1.100 s")


def test_a_byte_order_mark_is_accepted(capsys, tmp_path):
    marked = tmp_path / "bom.txt"
    marked.write_bytes(b"\xef\xbb\xbf" + ESTIMATE.read_bytes())
    assert run(capsys, GROUNDTRUTH, marked, "--json", tmp_path / "bom.json")[0] == 0
    assert run(capsys, GROUNDTRUTH, ESTIMATE, "--json", tmp_path / "plain.json")[0] == 0
    assert (tmp_path / "bom.json").read_text() == (tmp_path / "plain.json").read_text()


def test_piped_tables_are_never_cut(tmp_path):
    deep = tmp_path / ("a-folder-with-a-long-name-" * 4)
    deep.mkdir()
    estimate = deep / "freiburg1_xyz-rgbdslam.txt"
    shutil.copy(ESTIMATE, estimate)
    result = subprocess.run(
        [VIEWSLAM, "evaluate", GROUNDTRUTH, estimate, "--json", tmp_path / "e.json"],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "COLUMNS": "60"},
    )
    assert result.returncode == 0 and result.stderr == f"wrote {tmp_path / 'e.json'}\n"
    assert "…" not in result.stdout
    blocks = json.loads((tmp_path / "e.json").read_text())
    assert table_rows(result.stdout)[str(estimate)][-1] == f"{blocks['penalized_ate']['rmse']:.4f}"


def test_kitti_and_euroc_estimates_score_as_their_tum_twin(capsys, tmp_path):
    """The format is detected (KITTI takes the sequence's frame stamps) and named in the output."""
    sequence = tmp_path / "rgbd_dataset_freiburg1_rpy"
    shutil.copytree(TUM_RPY, sequence, ignore=shutil.ignore_patterns("*.png"))
    frames = open_source(sequence)
    poses, covered = frames.groundtruth_at(frames.timestamps)
    assert covered.all()
    estimate = perturbed(Trajectory(frames.timestamps, poses), seed=5, sigma_m=0.01)
    twins = [tmp_path / "e.txt", write_kitti(tmp_path / "e.kitti", estimate), write_euroc(tmp_path / "e.csv", estimate)]
    write_tum(twins[0], estimate)
    code, out, _ = run(capsys, sequence, *twins, "--json", tmp_path / "all.json")
    assert code == 0
    for path, name in zip(twins, ("TUM", "KITTI", "EuRoC")):
        assert f"{path}: read as {name}; coverage over" in out
    blocks = json.loads((tmp_path / "all.json").read_text())["estimates"]
    tum, kitti, euroc = (blocks[str(path)] for path in twins)
    assert tum["ate"]["rmse"] > 0.005  # a real error, not a trivially equal zero
    for other in (kitti, euroc):
        for key in ("ate", "ate_segments", "penalized_ate"):
            assert other[key] == pytest.approx(tum[key], abs=1e-6)  # TUM files hold 6 decimals
    code, _, err = run(capsys, GROUNDTRUTH, twins[1])
    assert code == 2 and err.startswith(f"viewslam: error: {twins[1]}: KITTI poses carry no timestamps")


def test_an_unwritable_output_is_refused_before_any_work_and_a_failed_run_keeps_the_last_good_one(capsys, tmp_path):
    folder = tmp_path / "taken"
    folder.mkdir()
    code, out, err = run(capsys, GROUNDTRUTH, ESTIMATE, "--json", folder)
    assert (code, out) == (2, "") and err == f"viewslam: error: {folder}: is a folder, not a file name\n"

    assert run(capsys, GROUNDTRUTH, ESTIMATE, "--json", tmp_path / "e.json", "--plot", tmp_path / "e.png")[0] == 0
    good = (tmp_path / "e.json").read_bytes(), (tmp_path / "e.png").read_bytes()
    late = bad_trajectory(tmp_path, GOOD_LINES)
    assert run(capsys, GROUNDTRUTH, late, "--json", tmp_path / "e.json", "--plot", tmp_path / "e.png")[0] == 2
    assert ((tmp_path / "e.json").read_bytes(), (tmp_path / "e.png").read_bytes()) == good
    assert sorted(path.name for path in tmp_path.iterdir()) == ["e.json", "e.png", "estimate.txt", "taken"]
