"""TUM evaluate_rpe.py's default RPE: Python 2.7's random module, the script's pairs, the study's printed figures."""

import math
import random
import re

import numpy as np
import pytest
from fixtures_eval import SHARED_DATA, TRAJECTORIES

from viewer_slam.cli import main
from viewer_slam.evaluation import evaluate
from viewer_slam.evaluation.python27_random import Python27Random
from viewer_slam.evaluation.tum_rpe import find_closest_index, pair_indices, tum_rpe
from viewer_slam.geometry.trajectory import read_tum

STUDY = SHARED_DATA / "study_kasar2018"
# (folder, system folder, trajectory file, result log) of the four shared sequences' eight runs
RUNS = [
    (folder, system, trajectory, log)
    for folder in (
        "freiburg2_360_kidnap",
        "freiburg3_long_office_household",
        "freiburg3_no_structure_no_texture",
        "freiburg3_sitting_static",
    )
    for system, trajectory, log in (
        ("rgbd", "rgbd_poses.txt", "rgbdresult.txt" if folder == "freiburg3_sitting_static" else "rgbd_result.txt"),
        ("rtab", "rtabmap_poses.txt", "rtabmap_result.txt"),
    )
]


# -- Python 2.7's generator ----------------------------------------------------------------


def test_mersenne_twister_seeding_and_floats_are_cpythons():
    """Integer seeding (init_by_array of the 32-bit words of |seed|) and the 53-bit float are the
    same C code in 2.7 and 3.x, so Python 3's generator is an oracle for them."""
    for seed in (0, 1, 42, 12345, 2**32 - 1, 2**32, 2**70 + 3, -7):
        ours, theirs = Python27Random(seed), random.Random(seed)
        assert [ours.random() for _ in range(1500)] == [theirs.random() for _ in range(1500)]  # crosses a twist
        assert [ours.getrandbits(k) for k in (1, 7, 31, 32, 33, 64, 95)] == [
            theirs.getrandbits(k) for k in (1, 7, 31, 32, 33, 64, 95)
        ]


def test_known_first_outputs_of_seed_0_and_42():
    """The documented first floats of ``random.seed(0)`` and ``random.seed(42)`` (identical in 2.7 and 3)."""
    generator = Python27Random(0)
    assert [generator.random() for _ in range(5)] == [
        0.8444218515250481,
        0.7579544029403025,
        0.420571580830845,
        0.25891675029296335,
        0.5112747213686085,
    ]
    assert Python27Random(42).random() == 0.6394267984578837


def test_integer_draws_are_2_7s_not_3s():
    """2.7 draws ``randint(a, b)`` as ``a + int(random() * (b - a + 1))``; Python 3 rejects on getrandbits."""
    generator = Python27Random(0)
    assert [generator.randint(0, 10) for _ in range(5)] == [9, 8, 4, 2, 5]  # int(11 * the floats above)
    assert Python27Random(0).randint(1, 100) == 85
    assert random.Random(0).randint(1, 100) == 50  # Python 3: another number from the same state
    stream = Python27Random(3)
    expected = [7 + int(stream.random() * 1000) for _ in range(200)]
    generator = Python27Random(3)
    assert [generator.randrange(7, 1007) for _ in range(200)] == expected
    assert Python27Random(3).choice("abcdefghij") == "abcdefghij"[int(Python27Random(3).random() * 10)]


def test_sample_follows_2_7s_two_algorithms():
    """Small populations: a pool with the picked slot refilled from the end; large ones: redraws against a set."""
    stream = Python27Random(5)
    pool, expected = list(range(10)), []
    for i in range(4):
        j = int(stream.random() * (10 - i))
        expected.append(pool[j])
        pool[j] = pool[10 - i - 1]
    assert Python27Random(5).sample(range(10), 4) == expected

    stream, picked = Python27Random(5), []
    while len(picked) < 30:
        j = int(stream.random() * 5000)
        if j not in picked:
            picked.append(j)
    assert Python27Random(5).sample(list(range(5000)), 30) == picked
    with pytest.raises(ValueError):
        Python27Random(0).sample([1, 2], 3)


# -- the script's pairs and search ----------------------------------------------------------


def test_under_100_poses_every_ordered_pair_else_10000_draws():
    first, second = pair_indices(15)
    assert len(first) == 225 and set(zip(first.tolist(), second.tolist())) == {
        (i, j) for i in range(15) for j in range(15)
    }
    first, second = pair_indices(100)
    generator = Python27Random(0)
    draws = [generator.randint(0, 99) for _ in range(20000)]
    assert first.tolist() == draws[0::2] and second.tolist() == draws[1::2]


def test_closest_index_is_the_binary_search_of_the_script():
    values = [0.0, 1.0, 2.0, 3.0, 4.0]
    # 3.5 is as close to 3 as to 4: the search visits 2, then 4, then 3, and keeps the first of equals (4)
    assert [find_closest_index(values, t) for t in (-5, 0.4, 0.6, 2.0, 3.5, 9)] == [0, 0, 1, 2, 4, 4]


def test_errors_follow_the_scripts_formula_on_a_hand_made_pair():
    """E = (P_j^-1 P_i)^-1 (Q_j^-1 Q_i): with Q identity and P_j a turn plus a step, |trans(E)| is the step."""
    turn = np.eye(4)
    turn[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    turn[:3, 3] = [1.0, 2.0, 0.0]
    stamps = np.array([0.0, 1.0])
    gt = np.stack([np.eye(4), np.eye(4)])
    result = tum_rpe(stamps, gt, stamps, np.stack([np.eye(4), turn]))
    assert len(result.translation) == 4  # (0,0), (0,1), (1,0), (1,1)
    assert sorted(result.translation.tolist()) == pytest.approx([0, 0, math.sqrt(5), math.sqrt(5)])
    assert sorted(result.rotation.tolist()) == pytest.approx([0, 0, math.pi / 2, math.pi / 2])


def test_pairs_far_from_any_groundtruth_stamp_are_dropped():
    gt_stamps = np.arange(0, 10, 0.01)
    gt = np.repeat(np.eye(4)[None], len(gt_stamps), axis=0)
    est_stamps = np.array([0.0, 1.0, 2.0, 50.0])  # the last one is 40 s after the groundtruth
    result = tum_rpe(gt_stamps, gt, est_stamps, np.repeat(np.eye(4)[None], 4, axis=0))
    assert len(result.translation) == 9


# -- the study's published figures -----------------------------------------------------------


def published(log_text: str) -> dict[str, float]:
    """The printed RPE block of an evaluate_rpe.py log (the lines after the last ``RPE``)."""
    block = log_text[log_text.rindex("RPE") :]
    figures = dict(re.findall(r"^(\w+\.\w+) ([\d.]+)", block, re.MULTILINE))
    figures["pairs"] = re.search(r"compared_pose_pairs (\d+)", block).group(1)
    return {key: float(value) for key, value in figures.items()}


@pytest.mark.parametrize("folder,system,trajectory,log", RUNS)
def test_the_study_rpe_is_reproduced_to_every_printed_digit(folder, system, trajectory, log):
    base = STUDY / folder / system
    figures = published((base / log).read_text())
    groundtruth, estimate = read_tum(base / "groundtruth.txt"), read_tum(base / trajectory)
    result = tum_rpe(groundtruth.timestamps, groundtruth.poses, estimate.timestamps, estimate.poses)
    trans, rot = result.translation, result.rotation
    assert len(trans) == figures["pairs"]
    printed = {
        "translational_error.rmse": np.sqrt(np.dot(trans, trans) / len(trans)),
        "translational_error.mean": np.mean(trans),
        "translational_error.median": np.median(trans),
        "translational_error.std": np.std(trans),
        "translational_error.max": np.max(trans),
        "rotational_error.rmse": np.sqrt(np.dot(rot, rot) / len(rot)) * 180 / np.pi,
        "rotational_error.mean": np.mean(rot) * 180 / np.pi,
        "rotational_error.median": np.median(rot) * 180 / np.pi,
        "rotational_error.std": np.std(rot) * 180 / np.pi,
        "rotational_error.max": np.max(rot) * 180 / np.pi,
    }
    for key, value in printed.items():
        assert f"{value:f}" == f"{figures[key]:f}", key
    evaluation = evaluate(groundtruth, estimate, rpe_mode="tum")  # the library path gives the same
    assert f"{evaluation.rpe_trans.stats()['rmse']:f}" == f"{figures['translational_error.rmse']:f}"
    assert f"{evaluation.rpe_rot.stats()['rmse']:f}" == f"{figures['rotational_error.rmse']:f}"


def test_evaluate_names_the_tum_mode(capsys, tmp_path):
    base = STUDY / "freiburg2_360_kidnap" / "rtab"
    code = main(
        [
            "evaluate",
            str(base / "groundtruth.txt"),
            str(base / "rtabmap_poses.txt"),
            "--rpe-mode",
            "tum",
            "--json",
            str(tmp_path / "e.json"),
        ]
    )
    out = capsys.readouterr().out
    assert code == 0
    assert "TUM evaluate_rpe.py's default" in out and "0.4496" in out
    import json

    rpe = json.loads((tmp_path / "e.json").read_text())["rpe"]
    assert rpe["mode"] == "tum" and rpe["trans"]["n"] == 225 and f"{rpe['trans']['rmse']:f}" == "0.449568"
    code = main(
        [
            "evaluate",
            str(TRAJECTORIES / "freiburg1_xyz-groundtruth.txt"),
            str(TRAJECTORIES / "freiburg1_xyz-rgbdslam.txt"),
            "--rpe-mode",
            "tum",
            "--all-deltas",
        ]
    )
    assert code == 2 and "--rpe-mode tum" in capsys.readouterr().err
