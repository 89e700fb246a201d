"""`viewslam study` against the author's files served from 127.0.0.1: hashes, figures, discrepancies, outputs."""

import functools
import http.server
import json
import shutil
import threading
from pathlib import Path

import jsonschema
import pytest
from fixtures_eval import SHARED_DATA

import viewer_slam
from viewer_slam.cli import main
from viewer_slam.study.manifest import SEQUENCES

STUDY = SHARED_DATA / "study_kasar2018"
SHARED = [sequence for sequence in SEQUENCES if (STUDY / sequence.folder).is_dir()]
SCHEMA = Path(viewer_slam.__file__).parent / "schemas" / "study_results.schema.json"


class QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args) -> None:
        pass


def serve(folder: Path):
    handler = functools.partial(QuietHandler, directory=str(folder))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server


@pytest.fixture
def mirror(tmp_path, monkeypatch):
    """The shared copy of the author's repository over HTTP, and an empty cache."""
    monkeypatch.setenv("VIEWSLAM_CACHE", str(tmp_path / "cache"))
    server = serve(STUDY)
    yield f"http://127.0.0.1:{server.server_address[1]}"
    server.shutdown()


def run_study(capsys, mirror, out, *extra) -> tuple[int, str, str]:
    code = main(
        ["study", *(sequence.name for sequence in SHARED), "--mirror", mirror, "--out", str(out), "--quiet", *extra]
    )
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def published_log(sequence, system: str) -> dict[str, str]:
    """The printed figures of a result log, read independently of the library (the last rmse lines of each block)."""
    sub = "rgbd" if system == "rgbdslam_v2" else "rtab"
    log = next(path for path in (STUDY / sequence.folder / sub).glob("*result*.txt"))
    text = log.read_text()
    ate, rpe = text[text.index("\nATE") : text.index("\nRPE")], text[text.index("\nRPE") :]
    pick = lambda block, key: block.split(key + " ")[1].split()[0]  # noqa: E731
    return {
        "ate_rmse": pick(ate, "absolute_translational_error.rmse"),
        "rpe_trans_rmse": pick(rpe, "translational_error.rmse"),
        "rpe_rot_rmse_deg": pick(rpe, "rotational_error.rmse"),
    }


def test_the_study_replays_every_logged_figure_or_reports_it(capsys, mirror, tmp_path):
    assert len(SHARED) == 4
    code, out, err = run_study(capsys, mirror, tmp_path / "out")
    assert code == 0, err
    results = json.loads((tmp_path / "out" / "results.json").read_text())
    jsonschema.validate(results, json.loads(SCHEMA.read_text()))
    assert len(results["rows"]) == 8 and all(row["sha256_verified"] for row in results["rows"])
    reported = {
        (entry["sequence"], entry["system"], entry["figure"])
        for entry in results["discrepancies"]
        if entry["source"] == "log"
    }
    matched = 0
    for row in results["rows"]:
        sequence = next(s for s in SHARED if s.name == row["sequence"])
        for figure, printed in published_log(sequence, row["system"]).items():
            agrees = f"{row['reproduced'][figure]:.6f}" == printed
            assert agrees != ((row["sequence"], row["system"], figure) in reported), (row["sequence"], figure)
            matched += agrees
    assert matched == 23  # of 24: one ATE log is stale (fr3/long_office_household, RGB-D SLAM)
    stale = [entry for entry in results["discrepancies"] if entry["source"] == "log"]
    assert [(entry["figure"], entry["published"]) for entry in stale] == [("ate_rmse", 0.028654)]


def test_chart_bars_under_another_sequences_label_are_found(capsys, mirror, tmp_path):
    code, _, _ = run_study(capsys, mirror, tmp_path / "out")
    assert code == 0
    results = json.loads((tmp_path / "out" / "results.json").read_text())
    rows = {(row["sequence"], row["system"]): row for row in results["rows"]}
    misplaced = [entry for entry in results["discrepancies"] if entry["kind"] == "misplaced"]
    assert misplaced and all(entry["figure"] == "rpe_trans_rmse" for entry in misplaced)
    for entry in misplaced:  # the bar is exactly the other sequence's reproduced figure, not its own
        other = rows[(entry["belongs_to"], entry["system"])]["reproduced"]["rpe_trans_rmse"]
        assert f"{other:.6f}" == f"{entry['published']:.6f}" != f"{entry['reproduced']:.6f}"


def test_coverage_and_penalised_ate_reverse_the_kidnap_ranking(capsys, mirror, tmp_path):
    code, out, _ = run_study(capsys, mirror, tmp_path / "out")
    assert code == 0
    rows = {
        row["system"]: row["reproduced"]
        for row in json.loads((tmp_path / "out" / "results.json").read_text())["rows"]
        if row["sequence"] == "rgbd_dataset_freiburg2_360_kidnap"
    }
    rtabmap, rgbdslam = rows["rtabmap"], rows["rgbdslam_v2"]
    assert rtabmap["ate_rmse"] < rgbdslam["ate_rmse"] and rtabmap["penalized_ate_rmse"] > rgbdslam["penalized_ate_rmse"]
    assert rtabmap["coverage"] == pytest.approx(0.299, abs=0.001) and len(rtabmap["lost_intervals"]) == 1
    assert rtabmap["stopped_at_s"] == pytest.approx(14.24, abs=0.01)
    report = (tmp_path / "out" / "report.md").read_text()
    assert "penalised ATE ranks RGB-D SLAM v2 first" in report and "| fr2/360_kidnap | RTAB-Map | 0.242387 |" in report
    for metric in ("ate_rmse", "rpe_trans_rmse", "rpe_rot_rmse", "time_s", "coverage", "penalized_ate_rmse"):
        assert (tmp_path / "out" / f"study_{metric}.png").read_bytes()[:4] == b"\x89PNG"


def test_a_file_that_is_not_the_studys_is_refused(capsys, mirror, tmp_path, monkeypatch):
    copy = tmp_path / "mirror"
    shutil.copytree(STUDY, copy)
    poses = copy / "freiburg2_360_kidnap" / "rtab" / "rtabmap_poses.txt"
    poses.chmod(0o644)
    poses.write_text(poses.read_text().replace("1311875146", "1311875147"))
    server = serve(copy)
    try:
        code, _, err = run_study(capsys, f"http://127.0.0.1:{server.server_address[1]}", tmp_path / "out")
    finally:
        server.shutdown()
    assert code == 2 and err.count("\n") == 1
    assert "rtabmap_poses.txt: SHA-256" in err and "is not the study's" in err
    assert not (tmp_path / "out" / "results.json").exists()


def test_cached_files_are_used_without_the_mirror_and_record_writes_recordings(capsys, mirror, tmp_path):
    assert run_study(capsys, mirror, tmp_path / "first")[0] == 0
    code, _, err = run_study(capsys, "http://127.0.0.1:9", tmp_path / "second", "--record")  # nothing listens there
    assert code == 0, err
    assert (tmp_path / "first" / "results.json").read_text() != ""
    for sequence in SHARED:
        assert (tmp_path / "second" / f"{sequence.name}.rrd").stat().st_size > 1000


def test_unknown_sequence_and_bad_mirror_are_one_line(capsys, mirror, tmp_path):
    assert main(["study", "fr9/nothing", "--out", str(tmp_path)]) == 2
    assert "fr9/nothing: not one of the study's sequences" in capsys.readouterr().err
    assert main(["study", "fr2/360_kidnap", "--mirror", "ftp:/x", "--out", str(tmp_path)]) == 2
    assert "--mirror 'ftp:/x': not a URL" in capsys.readouterr().err


def test_list_names_all_seven_sequences(capsys, mirror):
    assert main(["study", "--list"]) == 0
    out = capsys.readouterr().out
    assert len(out.splitlines()) == 7 and "freiburg2_360_pioneer_slam" in out and "fr2/pioneer_360" in out
