"""benchmarks.oracle refuses to compare without the original's build, or on frames that differ
from the listed ones (running the original is no test: it takes minutes and is not here)."""

import hashlib

import pytest

from benchmarks import oracle
from viewer_slam.errors import InputError


def test_without_the_original_it_refuses(tmp_path):
    with pytest.raises(InputError, match=f"{tmp_path}: no bin/rtabmap-rgbd_dataset"):
        oracle.main(["--oracle", str(tmp_path), "--out", str(tmp_path / "out")])
    assert not (tmp_path / "out").exists()


def test_frames_that_differ_from_the_list_are_refused(tmp_path):
    (tmp_path / "rgb").mkdir()
    (tmp_path / "depth").mkdir()
    for kind in ("rgb", "depth"):
        (tmp_path / kind / "1.png").write_bytes(kind.encode())
    listed = oracle.frame_digests(tmp_path)
    assert listed == {
        "rgb/1.png": hashlib.sha256(b"rgb").hexdigest(),
        "depth/1.png": hashlib.sha256(b"depth").hexdigest(),
    }
    oracle.check_frames(tmp_path, listed)  # the same frames: no word
    (tmp_path / "depth" / "1.png").write_bytes(b"another depth")
    with pytest.raises(InputError, match="1 frames differ from the listed SHA-256 .first: depth/1.png."):
        oracle.check_frames(tmp_path, listed)
    (tmp_path / "rgb" / "2.png").write_bytes(b"one more")
    with pytest.raises(InputError, match="2 frames differ"):
        oracle.check_frames(tmp_path, listed)


def test_a_missing_docs_block_is_refused_before_any_run(tmp_path):
    (tmp_path / "bin").mkdir()
    (tmp_path / "bin" / oracle.TOOL).write_text("")
    with pytest.raises(InputError, match="no oracle block 'no-such-block'"):
        oracle.main(["--oracle", str(tmp_path), "--docs", "--block", "no-such-block", "--out", str(tmp_path / "out")])
    assert not (tmp_path / "out").exists()


def test_the_table_gives_our_spread_over_seeds_and_the_default_seeds_value():
    run = {
        "resumptions": [(166, 80)],
        "maps": 2,
        "joining_links": 1,
        "all_joined": True,
        "loop_closures": 1,
        "proximity": 0,
        "nodes": 7,
        "node_ate": 2.0,
        "odometry_ate": 3.0,
        "frame_ate": 2.5,
    }
    ours = [run, {**run, "node_ate": 1.0, "resumptions": [(170, 60)]}]
    text = oracle.table("title", ours, [{**run, "node_ate": 0.5}, run])
    rows = {
        line.split(" | ")[0].lstrip("| "): line.split(" | ")[1:] for line in text.splitlines() if line.startswith("| ")
    }
    assert rows["ATE over the nodes (cm)"] == ["1.00–2.00; 2.00", "0.50–2.00 |"]
    assert rows["maps"] == ["2", "2 |"]  # the same in every run: no seed-0 value
    assert rows["resumes at frame (inliers)"][0] == "166–170 (60–80)"
    assert "ours, 2 seeds" in text and "2 runs" in text
