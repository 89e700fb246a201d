"""benchmarks.like_for_like on a reference made here: a tiny scene whose 'original' ran with the
groundtruth as its poses, so the replayed original must score an ATE of zero beside ours."""

import json

import pytest

from benchmarks import like_for_like
from benchmarks.reference import PER_FRAME, REFERENCE_NAME, THAT_BUILD
from viewer_slam.dataset.sources import open_source
from viewer_slam.errors import InputError
from viewer_slam.geometry.trajectory import write_tum

SEQUENCE = "rgbd_dataset_freiburg3_tiny"


@pytest.fixture(scope="module")
def reference(tiny_scene, tmp_path_factory):
    """(reference folder, TUM folder) with one per-frame run of the 'original' on the tiny scene."""
    root = tmp_path_factory.mktemp("like_for_like")
    (root / "tum").mkdir()
    (root / "tum" / SEQUENCE).symlink_to(tiny_scene)
    run = root / "reference" / f"{SEQUENCE}-perframe"
    run.mkdir(parents=True)
    sequence = open_source(tiny_scene)
    for name in ("poses_tum.txt", "db_poses_odom_tum.txt"):
        write_tum(run / name, sequence.groundtruth)
    header = "stamp,node_id,odom_inliers,odom_features,odom_local_map_size,odom_keyframe_added,loop_rejected\n"
    (run / "nodes.csv").write_text(
        header + "".join(f"{stamp:.6f},{i + 1},100,500,900,1,0\n" for i, stamp in enumerate(sequence.timestamps))
    )
    (run / "links.csv").write_text(
        "from_id,to_id,type_name\n" + "".join(f"{i},{i + 1},neighbor\n" for i in range(1, len(sequence)))
    )
    (run / "summary.json").write_text(json.dumps({"db": {"nodes": len(sequence), "links_by_type": {}}}))
    return root / "reference", root / "tum"


def test_ours_beside_the_original_replayed(reference, tmp_path, capsys):
    folder, tum = reference
    out = tmp_path / "out"
    assert (
        like_for_like.main(
            [SEQUENCE, "--reference", str(folder), "--tum", str(tum), "--out", str(out), "--param", "Vis/MinInliers=12"]
        )
        == 0
    )
    report = json.loads((out / f"{SEQUENCE}-perframe.json").read_text())
    runs = report["pipelines"]
    assert list(runs) == ["rtabmap", REFERENCE_NAME, f"{REFERENCE_NAME}-odometry"]
    assert runs["rtabmap"]["parameters"]["Vis/MinInliers"] == 12
    assert all(runs["rtabmap"]["parameters"][key] == value for key, value in {**PER_FRAME, **THAT_BUILD}.items())
    assert report["like_for_like"]["overrides"] == {**THAT_BUILD, **PER_FRAME, "Vis/MinInliers": "12"}
    assert runs[REFERENCE_NAME]["ate"]["rmse"] < 1e-5  # the groundtruth, replayed
    assert runs["rtabmap"]["frames_with_pose"] == 10 and runs["rtabmap"]["ate"]["rmse"] < 0.05
    for name in ("rtabmap", REFERENCE_NAME, f"{REFERENCE_NAME}-odometry", "rtabmap-odometry"):
        assert (out / f"{SEQUENCE}-perframe.{name}.txt").stat().st_size > 0
    summary = json.loads((out / f"{SEQUENCE}-perframe.summary.json").read_text())
    assert summary["reference"]["ate"]["rmse"] == runs[REFERENCE_NAME]["ate"]["rmse"]
    printed = capsys.readouterr().out
    assert "| inliers |" in printed and f"viewslam diff {out}" in printed


def test_no_reference_run_is_refused(tmp_path):
    with pytest.raises(InputError, match=f"{tmp_path}: no reference run"):
        like_for_like.main(["--reference", str(tmp_path)])


def test_a_bad_parameter_is_refused_before_the_run(reference, tmp_path):
    folder, tum = reference
    with pytest.raises(InputError, match="Vis/MinInliers expects an integer"):
        like_for_like.main(
            ["--reference", str(folder), "--tum", str(tum), "--out", str(tmp_path), "--param", "Vis/MinInliers=x"]
        )
    assert not list(tmp_path.iterdir())
