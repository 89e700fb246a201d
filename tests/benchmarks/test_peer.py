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


def test_the_untimed_first_frames_change_no_figure_but_the_rates(tiny_scene, capsys, monkeypatch):
    # each method's warm-up is a run of its own: the timed runs' ATEs are those of runs made alone
    monkeypatch.setattr(peer, "SEQUENCE_BLOCKS", {})
    assert peer.main(["--sequence", str(tiny_scene), "--frames", "6"]) == 0
    lines = capsys.readouterr().out.splitlines()
    rows = {line.split("|")[1].strip(): line.split("|") for line in lines if line.startswith("| ")}
    sequence = peer.open_source(str(tiny_scene))
    trajectory, _, _ = peer.open3d_odometry(sequence, 6)
    assert rows["Open3D RGB-D odometry"][2].strip() == f"{peer._ate_cm(sequence, trajectory):.2f} cm"
    for name, spec in peer.lab.pipeline_specs(peer.DEFAULT_PIPELINES).items():
        run = peer.lab.run(sequence, spec, name, max_frames=6).run
        alone = [f"{peer._ate_cm(sequence, trajectory):.2f} cm" for trajectory in (run.trajectory, run.odometry)]
        assert [cell.strip() for cell in rows[name][2:4]] == alone
