"""Association equals TUM's associate.py; ATE equals TUM's evaluate_ate.py on the same pairs."""

import numpy as np
import pytest
from fixtures_eval import TRAJECTORIES, read_tum_file_list, tum_associate, tum_horn_errors
from hypothesis import given, settings
from hypothesis import strategies as st

from viewer_slam.evaluation import evaluate
from viewer_slam.geometry.association import associate
from viewer_slam.geometry.trajectory import read_tum

REAL_PAIRS = [
    ("fr2_desk_groundtruth.txt", "fr2_desk_ORB.txt"),
    ("fr2_desk_groundtruth.txt", "fr2_desk_ORB_kf_mono.txt"),
    ("freiburg1_xyz-groundtruth.txt", "freiburg1_xyz-rgbdslam.txt"),
    ("freiburg1_xyz-groundtruth.txt", "freiburg1_xyz-ORB_kf_mono.txt"),
]


@pytest.mark.parametrize(("groundtruth_name", "estimate_name"), REAL_PAIRS)
@pytest.mark.parametrize(("offset", "max_difference"), [(0.0, 0.02), (0.013, 0.05)])
def test_pairs_on_real_files_are_tums(groundtruth_name, estimate_name, offset, max_difference):
    groundtruth = read_tum(TRAJECTORIES / groundtruth_name)
    estimate = read_tum(TRAJECTORIES / estimate_name)
    expected = tum_associate(
        list(read_tum_file_list(TRAJECTORIES / groundtruth_name)),
        list(read_tum_file_list(TRAJECTORIES / estimate_name)),
        offset,
        max_difference,
    )
    i, j = associate(groundtruth.timestamps, estimate.timestamps, offset, max_difference)
    assert list(zip(groundtruth.timestamps[i].tolist(), estimate.timestamps[j].tolist())) == expected


def test_fr2_desk_pair_count_and_duplicated_stamp_uses_the_last_row():
    groundtruth = read_tum(TRAJECTORIES / "fr2_desk_groundtruth.txt")
    estimate = read_tum(TRAJECTORIES / "fr2_desk_ORB.txt")
    duplicated = 1311868229.5760
    rows = np.flatnonzero(groundtruth.timestamps == duplicated)
    assert len(rows) == 2 and not np.array_equal(groundtruth.poses[rows[0]], groundtruth.poses[rows[1]])

    i, _ = associate(groundtruth.timestamps, estimate.timestamps)
    assert len(i) == 2223
    assert rows[0] not in i  # only the last of the repeated rows can be matched, as in TUM's dict
    first_rows, second_rows = associate([duplicated, duplicated], [duplicated])
    assert first_rows.tolist() == [1] and second_rows.tolist() == [0]


def test_evo_finds_two_more_pairs_on_fr2_desk_orb():
    """evo takes the nearest groundtruth stamp per estimate stamp, not a one-to-one matching."""
    from evo.core import sync
    from evo.tools import file_interface

    reference = file_interface.read_tum_trajectory_file(str(TRAJECTORIES / "fr2_desk_groundtruth.txt"))
    estimate = file_interface.read_tum_trajectory_file(str(TRAJECTORIES / "fr2_desk_ORB.txt"))
    reference, _ = sync.associate_trajectories(reference, estimate, max_diff=0.02)
    assert reference.num_poses == 2225


@settings(max_examples=60, deadline=None)
@given(
    first=st.lists(st.integers(0, 400), min_size=0, max_size=40),
    second=st.lists(st.integers(0, 400), min_size=0, max_size=40),
    offset=st.sampled_from([0.0, 0.01, -0.03]),
)
def test_random_stamps_with_ties_match_tums_rule(first, second, offset):
    """Stamps on a 10 ms grid make many candidates tie on their difference."""
    first_stamps = np.array(sorted(first), dtype=float) / 100
    second_stamps = np.array(sorted(second), dtype=float) / 100
    i, j = associate(first_stamps, second_stamps, offset, 0.035)
    expected = tum_associate(first_stamps.tolist(), second_stamps.tolist(), offset, 0.035)
    assert list(zip(first_stamps[i].tolist(), second_stamps[j].tolist())) == expected
    assert len(set(i.tolist())) == len(i) and len(set(j.tolist())) == len(j)


@pytest.mark.parametrize(("groundtruth_name", "estimate_name"), REAL_PAIRS[:3:2])
def test_ate_equals_tum_horn_on_tums_pairs(groundtruth_name, estimate_name):
    groundtruth_rows = read_tum_file_list(TRAJECTORIES / groundtruth_name)
    estimate_rows = read_tum_file_list(TRAJECTORIES / estimate_name)
    matches = tum_associate(list(groundtruth_rows), list(estimate_rows), 0.0, 0.02)
    data = np.array([[float(v) for v in groundtruth_rows[a][0:3]] for a, _ in matches]).T
    model = np.array([[float(v) for v in estimate_rows[b][0:3]] for _, b in matches]).T
    expected = tum_horn_errors(model, data)

    evaluation = evaluate(read_tum(TRAJECTORIES / groundtruth_name), read_tum(TRAJECTORIES / estimate_name))
    np.testing.assert_allclose(evaluation.ate.errors, expected, rtol=1e-9, atol=0)
    assert evaluation.ate.stats()["rmse"] == pytest.approx(np.sqrt(np.mean(expected**2)), rel=1e-12)
