"""`viewslam synth` errors and the generation cache."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from viewer_slam.cli import main
from viewer_slam.dataset.sources import open_source
from viewer_slam.dataset.synth import GENERATOR_VERSION, SCENARIOS, cached_scenario, generate_scenario, read_info

TINY = ["--frames", "6", "--resolution", "64x48"]


def test_unknown_scenario_exits_2_listing_the_scenarios(tmp_path, capsys):
    assert main(["synth", "office_party", "--out", str(tmp_path / "x")]) == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("viewslam: error: unknown scenario 'office_party'; valid: ")
    assert all(name in error for name in SCENARIOS) and "\n" not in error
    assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("resolution", ["640by480", "0x480", "640x", "99999x10"])
def test_bad_resolution_exits_2_naming_the_form(tmp_path, capsys, resolution):
    assert main(["synth", "360_kidnap", "--out", str(tmp_path / "x"), "--resolution", resolution]) == 2
    error = capsys.readouterr().err
    assert "WIDTHxHEIGHT" in error and error.count("\n") == 1


def test_unknown_camera_exits_2(tmp_path, capsys):
    assert main(["synth", "360_kidnap", "--out", str(tmp_path / "x"), "--camera", "kinect2", *TINY]) == 2
    assert "valid: fr1, fr2, fr3" in capsys.readouterr().err


def test_non_empty_folder_is_refused_without_force(tmp_path, capsys):
    out = tmp_path / "seq"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    assert main(["synth", "sitting_static", "--out", str(out), *TINY]) == 2
    assert "not empty; use --force" in capsys.readouterr().err
    assert main(["synth", "sitting_static", "--out", str(out), *TINY, "--force"]) == 0
    assert (out / "keep.txt").read_text() == "mine"
    assert len(open_source(out)) == 6
    assert (
        main(
            [
                "synth",
                "sitting_static",
                "--out",
                str(out),
                "--frames",
                "4",
                "--resolution",
                "64x48",
                "--force",
                "--camera",
                "fr1",
            ]
        )
        == 0
    )
    sequence = open_source(out)
    assert len(sequence) == 4 and len(list((out / "rgb").iterdir())) == 4
    assert sequence.camera.fx == pytest.approx(517.3 / 10)
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no staging folder left


def test_console_script_writes_a_sequence(tmp_path):
    result = subprocess.run(
        [
            Path(sys.executable).parent / "viewslam",
            "synth",
            "pioneer_360",
            "--out",
            str(tmp_path / "p"),
            *TINY,
            "--seed",
            "2",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    assert read_info(tmp_path / "p")["seed"] == 2


def test_cached_scenario_generates_once(tmp_path, monkeypatch):
    monkeypatch.setenv("VIEWSLAM_CACHE", str(tmp_path))
    folder = cached_scenario("nostructure_texture_near_withloop", frames=5, resolution=(64, 48), seed=1)
    assert folder == tmp_path / "synth" / f"nostructure_texture_near_withloop-5-64x48-s1-v{GENERATOR_VERSION}"
    stamp = (folder / "scenario.json").stat().st_mtime_ns
    assert cached_scenario("nostructure_texture_near_withloop", frames=5, resolution=(64, 48), seed=1) == folder
    assert (folder / "scenario.json").stat().st_mtime_ns == stamp
    assert [p.name for p in (tmp_path / "synth").iterdir()] == [folder.name]
    assert np.mean(open_source(folder).frame(0).depth > 0) > 0.97  # the plane fills the view


def _files(folder: Path) -> dict[str, bytes]:
    return {
        f"{kind}/{path.name}": path.read_bytes()
        for kind in ("rgb", "depth")
        for path in sorted((folder / kind).iterdir())
    }


def test_a_cut_renders_only_its_frames_byte_identical_to_the_whole_run(tmp_path, monkeypatch):
    monkeypatch.setenv("VIEWSLAM_CACHE", str(tmp_path / "cache"))
    size = {"frames": 10, "resolution": (64, 48), "seed": 1}
    cut = cached_scenario("360_kidnap", **size, first=4)
    assert cut.name.endswith("-first4") and len(open_source(cut)) == 4
    assert read_info(cut)["frames"] == 10 and read_info(cut)["rendered_frames"] == 4
    whole = generate_scenario("360_kidnap", tmp_path / "whole", **size)
    cut_files, whole_files = _files(cut), _files(whole)
    assert len(cut_files) == 8 and all(whole_files[name] == data for name, data in cut_files.items())
    assert (cut / "groundtruth.txt").read_bytes() == (whole / "groundtruth.txt").read_bytes()
    np.testing.assert_array_equal(open_source(cut).timestamps, open_source(whole).timestamps[:4])
    assert cached_scenario("360_kidnap", **size, first=3) == cut  # a longer cut serves a shorter one
    longer = cached_scenario("360_kidnap", **size, first=6)
    assert longer != cut and len(open_source(longer)) == 6  # never a short cut for a longer request
    complete = cached_scenario("360_kidnap", **size)
    assert "first" not in complete.name and len(open_source(complete)) == 10
    assert "rendered_frames" not in read_info(complete)
    assert cached_scenario("360_kidnap", **size, first=6) == complete  # the whole run serves every cut


def test_rendering_shows_frames_rate_and_time_left_unless_quiet(tmp_path, capsys):
    generate_scenario("sitting_static", tmp_path / "a", frames=5, resolution=(64, 48), progress=True)
    captured = capsys.readouterr()
    assert "rendering sitting_static" in captured.err and "5/5" in captured.err and "frames/s" in captured.err
    assert captured.out == ""
    assert main(["synth", "sitting_static", "--out", str(tmp_path / "b"), *TINY, "--quiet"]) == 0
    assert "rendering" not in capsys.readouterr().err
