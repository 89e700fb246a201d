"""Known sequences: TUM names and aliases, folders, synthetic scenarios, helpful errors."""

import pytest

from benchmark_fake_pipeline import write_tum_folder
from viewer_slam.cli import main
from viewer_slam.dataset.catalog import TUM_SEQUENCES, resolve_sequence, tum_sequence
from viewer_slam.dataset.download import TUM_MIRROR, archive_url
from viewer_slam.dataset.synth import SCENARIOS
from viewer_slam.dataset.tum import open_sequence
from viewer_slam.errors import InputError

# The seven sequences of the study.
STUDY = ("fr2/desk_with_person", "fr2/pioneer_360", "fr2/360_kidnap", "fr3/long_office_household",
         "fr3/nostructure_notexture_near_withloop", "fr3/nostructure_texture_near_withloop", "fr3/sitting_static")


@pytest.fixture(autouse=True)
def cache(monkeypatch, tmp_path):
    monkeypatch.setenv("VIEWSLAM_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


def test_tum_catalogue_names_aliases_and_archives():
    assert len(TUM_SEQUENCES) == 47
    assert len({info.name for info in TUM_SEQUENCES}) == len({info.alias for info in TUM_SEQUENCES}) == 47
    kidnap = tum_sequence("fr2/360_kidnap")
    assert kidnap is tum_sequence("rgbd_dataset_freiburg2_360_kidnap") is tum_sequence("freiburg2_360_kidnap")
    assert (kidnap.camera, kidnap.category) == ("freiburg2", "handheld")
    assert archive_url(kidnap) == "https://cvg.cit.tum.de/rgbd/dataset/freiburg2/rgbd_dataset_freiburg2_360_kidnap.tgz"
    assert archive_url(kidnap, "http://mirror/x/") == "http://mirror/x/freiburg2/rgbd_dataset_freiburg2_360_kidnap.tgz"
    assert TUM_MIRROR == "https://cvg.cit.tum.de/rgbd/dataset"
    assert all(tum_sequence(alias) is not None for alias in STUDY)
    assert tum_sequence("fr4/xyz") is None


def test_folder_resolves_to_itself(tmp_path):
    folder = write_tum_folder(tmp_path / "anything", frames=2)
    assert resolve_sequence(str(folder)) == folder


def test_tum_name_needs_a_download_then_resolves(cache):
    with pytest.raises(InputError, match=r"^fr2/360_kidnap: TUM sequence not downloaded; "
                                         r"run `viewslam download fr2/360_kidnap`$"):
        resolve_sequence("fr2/360_kidnap")
    folder = write_tum_folder(cache / "tum" / "rgbd_dataset_freiburg2_360_kidnap", frames=2)
    assert resolve_sequence("fr2/360_kidnap") == folder == resolve_sequence("rgbd_dataset_freiburg2_360_kidnap")


def test_scenario_name_generates_into_the_cache(cache):
    folder = resolve_sequence("360_kidnap", frames=6, resolution=(64, 48))
    assert folder.is_relative_to(cache)
    sequence = open_sequence(folder)
    assert len(sequence) == 6 and (sequence.camera.width, sequence.camera.height) == (64, 48)
    assert resolve_sequence("360_kidnap", frames=6, resolution=(64, 48)) == folder


def test_unknown_sequence_lists_the_valid_names(capsys):
    assert main(["benchmark", "fr9/mystery", "--out", "unused"]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and error.startswith("viewslam: error: fr9/mystery: not a folder")
    assert all(name in error for name in SCENARIOS) and all(alias in error for alias in STUDY)


def test_sequences_command_lists_scenarios_and_downloads(cache, capsys):
    write_tum_folder(cache / "tum" / "rgbd_dataset_freiburg1_xyz", frames=2)
    assert main(["sequences"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert all(f"  {name}" in lines for name in SCENARIOS)
    [xyz] = [line for line in lines if "rgbd_dataset_freiburg1_xyz" in line]
    assert xyz.split() == ["fr1/xyz", "rgbd_dataset_freiburg1_xyz", "testing", "downloaded"]
    assert sum(line.endswith("downloaded") for line in lines) == 1
    assert len(lines) == 2 + len(SCENARIOS) + 47
