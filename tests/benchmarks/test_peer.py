"""benchmarks.peer: Open3D's odometry and the pipelines over the same frames, in one table."""

import pytest

from benchmarks import peer
from viewer_slam.errors import InputError


def test_the_table_of_the_peer_and_a_pipeline(tiny_scene, capsys, monkeypatch):
    monkeypatch.setattr(peer, "SEQUENCE_BLOCKS", {})  # nothing written into the docs
    assert (
        peer.main(
            ["--sequence", str(tiny_scene), "--frames", "6", "--pipelines", "rtabmap", "--param", "Vis/MinInliers=12"]
        )
        == 0
    )
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == f"sequence {tiny_scene.name}: 6 frames, 320x240"
    rows = {line.split("|")[1].strip(): line for line in lines if line.startswith("| ")}
    assert set(rows) == {"method", "Open3D RGB-D odometry", "rtabmap"}
    ate = float(rows["rtabmap"].split("|")[2].removesuffix(" cm "))
    assert 0 <= ate < 5
    assert lines[-1].startswith("rtabmap: `features` ")


def test_a_parameter_no_pipeline_has_is_refused(tiny_scene):
    with pytest.raises(InputError, match="unknown parameter 'Vis/MinInliers' for rgbdslam"):
        peer.main(["--sequence", str(tiny_scene), "--pipelines", "rgbdslam", "--param", "Vis/MinInliers=12"])
