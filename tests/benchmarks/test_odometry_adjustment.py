"""benchmarks.odometry_adjustment: the odometry in three builds' configurations on the same
frames, its errors into a figure block; bad input refused before any run."""

import pytest

from benchmarks import odometry_adjustment
from benchmarks.figures import written
from viewer_slam.errors import InputError


def test_each_configuration_is_measured_on_the_same_frames_into_the_block(tiny_scene, tmp_path, monkeypatch):
    document = tmp_path / "rtabmap.md"
    document.write_text("<!-- figures: odometry-adjustment -->\nold\n<!-- /figures: odometry-adjustment -->\n")
    monkeypatch.setattr(odometry_adjustment, "DOCUMENT", document)
    assert odometry_adjustment.main([str(tiny_scene), "--frames", "6", "--seeds", "1", "--docs"]) == 0
    block = written(document.read_text(), "odometry-adjustment")
    assert block.startswith(f"Made by `python -m benchmarks.odometry_adjustment {tiny_scene} --frames 6 ")
    header, _, row = [line for line in block.splitlines() if line.startswith("|")]
    assert [cell.split(":")[0].strip() for cell in header.split("|")[3:-1]] == list(odometry_adjustment.CONFIGURATIONS)
    cells = [cell.strip() for cell in row.split("|")[1:-1]]
    assert cells[0] == tiny_scene.name and 0 < float(cells[1]) < 10  # median depth, metres
    for cell in cells[2:]:
        errors, frames = cell.split(" (")
        rpe, ate = (float(value) for value in errors.split(" / "))
        assert frames == "6 frames)" and rpe > 0 and ate >= 0  # every frame tracked, each measured


@pytest.mark.parametrize(
    "arguments, message",
    [
        ([], "no frames: give a TUM folder or --render SCENE:SEED"),
        (["--render", "360_kidnap"], "--render 360_kidnap: expected SCENE:SEED"),
        (["--frames", "1", "x"], "--frames must be at least 2"),
    ],
)
def test_bad_arguments_are_refused_in_one_line(arguments, message, tmp_path):
    with pytest.raises(InputError, match=message):
        odometry_adjustment.main([*arguments, "--out", str(tmp_path / "out")])
    assert not (tmp_path / "out").exists()


def test_a_folder_without_groundtruth_is_refused(tiny_scene, tmp_path):
    folder = tmp_path / "no_groundtruth"
    folder.mkdir()
    for entry in tiny_scene.iterdir():
        if entry.name != "groundtruth.txt":
            (folder / entry.name).symlink_to(entry)
    with pytest.raises(InputError, match="no groundtruth.txt"):
        odometry_adjustment.main([str(folder), "--frames", "3", "--seeds", "1"])
