"""Known sequences: TUM names and aliases, folders, synthetic scenarios, helpful errors."""

from collections import Counter

import pytest
from benchmark_fake_pipeline import write_tum_folder
from rich.filesize import decimal

from viewer_slam.cli import main
from viewer_slam.dataset.catalog import TUM_SEQUENCES, known_tum_sequence, resolve_sequence, tum_cache_dir, tum_sequence
from viewer_slam.dataset.download import TUM_MIRROR, archive_url
from viewer_slam.dataset.sources import open_source
from viewer_slam.dataset.synth import SCENARIOS
from viewer_slam.errors import InputError

# The seven sequences of the study.
STUDY = (
    "fr2/desk_with_person",
    "fr2/pioneer_360",
    "fr2/360_kidnap",
    "fr3/long_office_household",
    "fr3/nostructure_notexture_near_withloop",
    "fr3/nostructure_texture_near_withloop",
    "fr3/sitting_static",
)


@pytest.fixture(autouse=True)
def cache(monkeypatch, tmp_path):
    monkeypatch.setenv("VIEWSLAM_CACHE", str(tmp_path / "cache"))
    monkeypatch.delenv("VIEWSLAM_DATA", raising=False)
    monkeypatch.delenv("VIEWSLAM_TUM_MIRROR", raising=False)
    return tmp_path / "cache"


def test_tum_catalogue_names_aliases_and_archives():
    assert len(TUM_SEQUENCES) == 80
    assert len({info.name for info in TUM_SEQUENCES}) == len({info.alias for info in TUM_SEQUENCES}) == 80
    categories = Counter(info.category for info in TUM_SEQUENCES)
    assert categories == {
        "testing": 4,
        "handheld": 11,
        "robot": 4,
        "structure_texture": 8,
        "dynamic": 9,
        "object_reconstruction": 11,
        "validation": 33,
    }
    assert Counter(info.camera for info in TUM_SEQUENCES) == {"freiburg1": 16, "freiburg2": 25, "freiburg3": 39}
    kidnap = tum_sequence("fr2/360_kidnap")
    assert kidnap is tum_sequence("rgbd_dataset_freiburg2_360_kidnap") is tum_sequence("freiburg2_360_kidnap")
    assert (kidnap.camera, kidnap.category, kidnap.groundtruth_public) == ("freiburg2", "handheld", True)
    hidden = tum_sequence("fr3/walking_xyz_validation")
    assert (hidden.name, hidden.category, hidden.groundtruth_public) == (
        "rgbd_dataset_freiburg3_walking_xyz_validation",
        "validation",
        False,
    )
    assert archive_url(kidnap) == "https://cvg.cit.tum.de/rgbd/dataset/freiburg2/rgbd_dataset_freiburg2_360_kidnap.tgz"
    assert archive_url(kidnap, "http://mirror/x/") == "http://mirror/x/freiburg2/rgbd_dataset_freiburg2_360_kidnap.tgz"
    assert TUM_MIRROR == "https://cvg.cit.tum.de/rgbd/dataset"
    assert all(tum_sequence(alias) is not None for alias in STUDY)
    assert tum_sequence("fr4/xyz") is None


def test_folder_resolves_to_itself(tmp_path):
    folder = write_tum_folder(tmp_path / "anything", frames=2)
    assert resolve_sequence(str(folder)) == folder


def test_tum_name_needs_a_download_then_resolves(cache):
    with pytest.raises(
        InputError,
        match=r"^fr2/360_kidnap: TUM sequence not downloaded; "
        r"run `viewslam download fr2/360_kidnap`$",
    ):
        resolve_sequence("fr2/360_kidnap")
    folder = write_tum_folder(cache / "tum" / "rgbd_dataset_freiburg2_360_kidnap", frames=2)
    assert resolve_sequence("fr2/360_kidnap") == folder == resolve_sequence("rgbd_dataset_freiburg2_360_kidnap")


def test_scenario_name_generates_into_the_cache(cache):
    folder = resolve_sequence("360_kidnap", frames=6, resolution=(64, 48))
    assert folder.is_relative_to(cache)
    sequence = open_source(folder)
    assert len(sequence) == 6 and (sequence.camera.width, sequence.camera.height) == (64, 48)
    assert resolve_sequence("360_kidnap", frames=6, resolution=(64, 48)) == folder


def test_unknown_sequence_lists_the_valid_names(capsys):
    assert main(["benchmark", "fr9/mystery", "--out", "unused"]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and error.startswith("viewslam: error: fr9/mystery: not a folder")
    assert all(name in error for name in SCENARIOS)
    assert f"`viewslam sequences` lists the {len(TUM_SEQUENCES)} TUM sequences" in error
    assert "did you mean" not in error


def test_misspelt_sequence_suggests_the_close_names(capsys):
    assert main(["record", "fr3/sitting_statc", "--quiet"]) == 2
    assert (
        "fr3/sitting_statc: not a folder, synthetic scenario or TUM sequence; did you mean fr3/sitting_static or "
        "sitting_static or fr3/sitting_xyz? scenarios: " in capsys.readouterr().err
    )
    with pytest.raises(InputError, match=r"; did you mean 360_kidnap or fr2/360_kidnap\? "):
        resolve_sequence("360_kidnapp")
    with pytest.raises(InputError, match=r"^fr1/xzy: unknown TUM sequence; did you mean fr1/xyz\? "):
        known_tum_sequence("fr1/xzy")


def test_sequences_command_lists_scenarios_and_downloads(cache, capsys):
    write_tum_folder(cache / "tum" / "rgbd_dataset_freiburg1_xyz", frames=2)
    assert main(["sequences"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert all(f"  {name}" in lines for name in SCENARIOS)
    rows = [
        line.split()
        for line in lines[
            2 + len(SCENARIOS) : lines.index(
                "frN/NAME stands for the folder rgbd_dataset_freiburgN_NAME; commands accept either."
            )
        ]
    ]
    assert ["fr1/xyz", "testing", "groundtruth", "downloaded"] in rows
    assert ["fr1/xyz_validation", "validation", "no-groundtruth"] in rows
    assert sum(row[-1] == "downloaded" for row in rows) == 1
    assert len(rows) == 80


def test_viewslam_data_is_where_tum_names_are_looked_up(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv("VIEWSLAM_DATA", str(tmp_path / "data"))
    folder = write_tum_folder(tmp_path / "data" / "rgbd_dataset_freiburg2_360_kidnap", frames=2)
    assert tum_cache_dir() == tmp_path / "data" and resolve_sequence("fr2/360_kidnap") == folder
    assert main(["sequences"]) == 0
    assert f"TUM RGB-D sequences (downloads in {tmp_path / 'data'}):" in capsys.readouterr().out


def test_the_cache_follows_xdg_unless_viewslam_cache_is_set(tmp_path, monkeypatch):
    from viewer_slam.cache import cache_dir

    monkeypatch.delenv("VIEWSLAM_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_dir("synth") == tmp_path / "xdg" / "viewslam" / "synth"
    monkeypatch.setenv("VIEWSLAM_CACHE", str(tmp_path / "own"))
    assert cache_dir("synth") == tmp_path / "own" / "synth"


def test_sequences_shows_the_cache_entry_by_entry_and_clears_all_but_the_downloads(cache, capsys):
    write_tum_folder(cache / "tum" / "rgbd_dataset_freiburg1_xyz", frames=2)
    render = cache / "synth" / "360_kidnap-6-64x48-s0-v1"
    render.mkdir(parents=True)
    (render / "frame.png").write_bytes(bytes(3000))
    (cache / "benchmark").mkdir()
    (cache / "benchmark" / "result.json").write_bytes(bytes(500))
    rendering = cache / "synth" / ".360_kidnap-600-64x48-s0-v1.x1y2z3" / "run"  # another process renders into it
    rendering.mkdir(parents=True)
    (rendering / "frame.png").write_bytes(bytes(700))
    assert main(["sequences"]) == 0
    lines = capsys.readouterr().out.splitlines()
    total = sum(path.stat().st_size for path in cache.rglob("*") if path.is_file())
    heading = next(i for i, line in enumerate(lines) if line.startswith("Cache "))
    assert lines[heading] == f"Cache {cache} ($VIEWSLAM_CACHE): {decimal(total)}"
    entries = {line.split()[0]: " ".join(line.split()[1:]) for line in lines[heading + 1 : -1]}
    assert entries == {
        "benchmark": "500 bytes",
        "synth/360_kidnap-6-64x48-s0-v1": "3.0 kB",
        "synth/.360_kidnap-600-64x48-s0-v1.x1y2z3": "700 bytes",
        "tum/rgbd_dataset_freiburg1_xyz": decimal(total - 4200),
    }
    assert main(["sequences", "--clear-cache"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("Removed 2 cache entries, 3.5 kB.\n")
    assert not render.exists() and not (cache / "benchmark").exists()
    assert (rendering / "frame.png").is_file()  # a render in progress is left to the process making it
    assert (cache / "tum" / "rgbd_dataset_freiburg1_xyz" / "rgb.txt").is_file()
