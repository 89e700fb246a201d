"""TUM, KITTI and EuRoC/ASL trajectory files: detection, exact reading, and one-line errors."""

import numpy as np
import pytest
from fixtures_eval import perturbed, random_walk
from trajectory_writers import nanoseconds, write_euroc, write_kitti

from viewer_slam.errors import InputError
from viewer_slam.evaluation import evaluate
from viewer_slam.geometry.se3 import pose_to_tq
from viewer_slam.geometry.trajectory import Trajectory, write_tum
from viewer_slam.geometry.trajectory_formats import read_trajectory

EUROC_GROUNDTRUTH_HEADER = (
    "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], "
    "q_RS_z [], v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], "
    "b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], "
    "b_a_RS_S_z [m s^-2]"
)


@pytest.fixture
def truth():
    return random_walk(120, seed=3)


@pytest.fixture
def estimate(truth):
    return perturbed(truth, seed=4, sigma_m=0.02)


def test_kitti_and_euroc_of_the_same_trajectory_give_the_same_ate_as_tum(tmp_path, truth, estimate):
    write_tum(tmp_path / "estimate.txt", estimate)
    tum, tum_format = read_trajectory(tmp_path / "estimate.txt")
    kitti, kitti_format = read_trajectory(
        write_kitti(tmp_path / "estimate.kitti", estimate), timestamps=estimate.timestamps
    )
    euroc, euroc_format = read_trajectory(write_euroc(tmp_path / "estimate.csv", estimate))
    assert (tum_format, kitti_format, euroc_format) == ("tum", "kitti", "euroc")
    scores = [evaluate(truth, trajectory) for trajectory in (kitti, euroc)]
    assert scores[0].ate.stats()["n"] == scores[1].ate.stats()["n"] == len(truth)
    assert scores[0].ate.stats()["rmse"] > 0.01  # a real error, not a trivially equal zero
    np.testing.assert_allclose(scores[0].ate.errors, scores[1].ate.errors, rtol=0, atol=1e-9)
    # TUM rounds to micrometres and microseconds; the other two keep every digit.
    np.testing.assert_allclose(evaluate(truth, tum).ate.errors, scores[1].ate.errors, rtol=0, atol=5e-6)


def test_kitti_poses_are_read_exactly_with_the_given_or_filed_stamps(tmp_path, estimate):
    path = write_kitti(tmp_path / "poses.txt", estimate)
    times = tmp_path / "times.txt"
    times.write_text("".join(f"{float(stamp)!r}\n" for stamp in estimate.timestamps))
    for stamps in (estimate.timestamps, times):
        trajectory, _ = read_trajectory(path, "kitti", timestamps=stamps)
        np.testing.assert_array_equal(trajectory.timestamps, estimate.timestamps)
        np.testing.assert_allclose(trajectory.poses, estimate.poses, rtol=0, atol=1e-12)


def test_euroc_groundtruth_columns_are_found_by_name_and_stamps_kept_to_the_nanosecond(tmp_path, estimate):
    stamps = 1403636579.758555392 + np.arange(len(estimate)) / 200
    moved = Trajectory(stamps, estimate.poses)
    path = write_euroc(tmp_path / "data.csv", moved, EUROC_GROUNDTRUTH_HEADER, extra_columns=9)
    trajectory, name = read_trajectory(path)
    assert name == "euroc"
    assert trajectory.timestamps.tolist() == [ns / 10**9 for ns in nanoseconds(stamps)]
    np.testing.assert_allclose(trajectory.poses, estimate.poses, rtol=0, atol=1e-12)


def test_euroc_columns_in_another_order(tmp_path, estimate):
    t, q = pose_to_tq(estimate.poses)
    rows = [
        f"{ns},{r[3]:.17g},{r[0]:.17g},{r[1]:.17g},{r[2]:.17g},{p[0]:.17g},{p[1]:.17g},{p[2]:.17g}"
        for ns, p, r in zip(nanoseconds(estimate.timestamps), t, q)
    ]
    path = tmp_path / "reordered.csv"
    path.write_text("timestamp,qw,qx,qy,qz,x,y,z\n" + "\n".join(rows) + "\n")
    trajectory, _ = read_trajectory(path)
    np.testing.assert_allclose(trajectory.poses, estimate.poses, rtol=0, atol=1e-12)


def test_a_tum_groundtruth_with_comments_is_detected_as_tum(tmp_path, estimate):
    path = tmp_path / "groundtruth.txt"
    write_tum(path, estimate)
    path.write_text("# ground truth trajectory\n# timestamp tx ty tz qx qy qz qw\n" + path.read_text())
    assert read_trajectory(path)[1] == "tum"


GOOD_KITTI = "1 0 0 0 0 1 0 0 0 0 1 0\n"
EUROC = "#timestamp [ns],tx,ty,tz,qw,qx,qy,qz\n"


@pytest.mark.parametrize(
    "name, text, options, where, problem",
    [
        pytest.param(
            "t.txt",
            "1 0 0 0 0 0 0 1\n",
            {"format": "orb"},
            "",
            "unknown trajectory format 'orb'; valid: tum, kitti, euroc",
            id="unknown-format",
        ),
        pytest.param("t.txt", "1 0 0 0 0 0 0 1\n2 0 0 0 0 0 1\n", {}, ":2", "expected 8 fields", id="tum-columns"),
        pytest.param("t.txt", "2 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n", {}, ":2", "does not increase", id="tum-order"),
        pytest.param("t.txt", "1 0 0 0 0 0 0 1\n2 0 nan 0 0 0 0 1\n", {}, ":2", "NaN or infinite", id="tum-nan"),
        pytest.param(
            "k.txt",
            GOOD_KITTI + "1 0 0 0 0 1 0 0 0 0 1\n",
            {"format": "kitti", "timestamps": [0, 1]},
            ":2",
            "expected 12 fields",
            id="kitti-columns",
        ),
        pytest.param(
            "k.txt",
            GOOD_KITTI + GOOD_KITTI.replace("1 0 0 0", "1 0 0 nan", 1),
            {"timestamps": [0, 1]},
            ":2",
            "NaN or infinite",
            id="kitti-nan",
        ),
        pytest.param(
            "k.txt",
            GOOD_KITTI + "2 0 0 0 0 1 0 0 0 0 1 0\n",
            {"timestamps": [0, 1]},
            ":2",
            "not a rotation matrix",
            id="kitti-not-rotation",
        ),
        pytest.param("k.txt", GOOD_KITTI, {}, "", "KITTI poses carry no timestamps", id="kitti-no-stamps"),
        pytest.param(
            "k.txt", GOOD_KITTI * 2, {"timestamps": [0.0]}, "", "2 KITTI poses but 1 timestamps", id="kitti-count"
        ),
        pytest.param(
            "e.csv",
            EUROC + "1,0,0,0,1,0,0,0\n3,0,0\n",
            {},
            ":3",
            "expected 8 fields as the header names",
            id="euroc-columns",
        ),
        pytest.param(
            "e.csv", EUROC + "5,0,0,0,1,0,0,0\n5,0,0,0,1,0,0,0\n", {}, ":3", "does not increase", id="euroc-order"
        ),
        pytest.param("e.csv", EUROC + "1,0,0,0,nan,0,0,0\n", {}, ":2", "NaN or infinite", id="euroc-nan"),
        pytest.param(
            "e.csv",
            "#timestamp [ns],tx,ty,tz,a,b,c,d\n1,0,0,0,1,0,0,0\n",
            {},
            ":1",
            "the header names no quaternion x column",
            id="euroc-header",
        ),
        pytest.param(
            "e.csv", "1 0 0 0 0 0 0 1\n", {"format": "euroc"}, ":1", "not an EuRoC/ASL CSV", id="euroc-forced"
        ),
        pytest.param("missing.txt", None, {}, "", "no such file", id="missing"),
        pytest.param("binary.txt", b"\xff\xfe\x00garbage", {}, "", "cannot read", id="unreadable"),
    ],
)
def test_bad_trajectory_files_name_the_file_line_and_problem(tmp_path, name, text, options, where, problem):
    path = tmp_path / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    elif text is not None:
        path.write_text(text)
    with pytest.raises(InputError) as raised:
        read_trajectory(path, **options)
    message = str(raised.value)
    assert message.startswith(f"{path}{where}: ") and problem in message and "\n" not in message
