"""RTAB-Map building blocks against hand-computed values and exhaustive oracles."""

import cv2
import numpy as np
import pytest

from viewer_slam.geometry.se3 import exp_so3, invert, make_pose
from viewer_slam.pipelines.params import resolve_params
from viewer_slam.pipelines.rtabmap import PIPELINE, RtabmapParams
from viewer_slam.pipelines.rtabmap.bayes import NEW_PLACE, BayesFilter, likelihood
from viewer_slam.pipelines.rtabmap.graph import LocationGraph, registration_variance
from viewer_slam.pipelines.rtabmap.memory import Location, Memory, similarity
from viewer_slam.pipelines.rtabmap.odometry import LocalMap, guided_matches, hamming_distances
from viewer_slam.pipelines.rtabmap.vocabulary import REBUILD_PENDING, Vocabulary

RNG = np.random.default_rng(0)


def descriptors(count: int, rng=RNG) -> np.ndarray:
    return rng.integers(0, 256, (count, 32), dtype=np.uint8)


def flip_bits(d: np.ndarray, bits: int, rng=RNG) -> np.ndarray:
    """Copies of ``d`` with ``bits`` random bits flipped in each row."""
    unpacked = np.unpackbits(d, axis=1)
    for row in unpacked:
        row[rng.choice(256, bits, replace=False)] ^= 1
    return np.packbits(unpacked, axis=1)


def test_parameters_carry_rtabmap_names_and_defaults():
    resolved = resolve_params({"rtabmap": RtabmapParams}, ["Odom/ResetCountdown=5", "Rtabmap/MemoryThr=30"])
    params = resolved["rtabmap"]
    assert (params.reset_countdown, params.memory_threshold) == (5, 30)
    defaults = RtabmapParams()
    assert (defaults.loop_threshold, defaults.stm_size, defaults.local_map_size, defaults.min_inliers) == (0.11, 10, 2000, 20)
    assert PIPELINE.name == "rtabmap" and PIPELINE.Params is RtabmapParams


def test_guided_matching_only_pairs_features_with_map_points_projected_nearby():
    map_descriptors = descriptors(6)
    projections = np.array([[10, 10], [100, 100], [200, 50], [300, 200], [50, 200], [250, 120]], float)
    features = flip_bits(map_descriptors, 8)
    # Feature k sits 3 px from map point k's projection, except feature 2, placed 60 px away.
    keypoints = projections + 3.0
    keypoints[2] += 60
    query, train = guided_matches(keypoints, features, projections, map_descriptors, window=20, nndr=0.8)
    assert sorted(zip(query.tolist(), train.tolist())) == [(0, 0), (1, 1), (3, 3), (4, 4), (5, 5)]


def test_guided_matching_ratio_test_drops_ambiguous_candidates():
    twin = descriptors(1)
    map_descriptors = np.vstack([twin, twin])
    projections = np.array([[50.0, 50.0], [55.0, 50.0]])
    query, _ = guided_matches(np.array([[52.0, 50.0]]), flip_bits(twin, 4), projections, map_descriptors, 20, 0.8)
    assert len(query) == 0


def test_hamming_distances_match_bit_counts():
    a, b = descriptors(5), descriptors(5)
    expected = [int(np.unpackbits(x ^ y).sum()) for x, y in zip(a, b)]
    assert hamming_distances(a, b).tolist() == expected


def test_local_map_cap_keeps_the_most_recently_seen_points():
    local_map = LocalMap()
    for frame in range(5):
        local_map.add(np.full((10, 3), frame, float), descriptors(10), frame)
    local_map.observe(np.arange(5), 9)          # five points of frame 0 seen again last
    local_map.cap(25)
    assert len(local_map) == 25
    assert sorted(set(local_map.points[:, 0].tolist())) == [0.0, 3.0, 4.0]
    assert (local_map.last_seen == 9).sum() == 5


def test_vocabulary_reuses_words_and_creates_new_ones():
    vocabulary = Vocabulary(nndr=0.8)
    base = descriptors(300)
    first = vocabulary.add_location(0, base)
    assert sorted(first.tolist()) == list(range(300)) and len(vocabulary) == 300
    again = vocabulary.add_location(1, np.vstack([flip_bits(base[:200], 10), descriptors(50)]))
    assert np.array_equal(again[:200], first[:200])
    assert set(again[200:].tolist()) == set(range(300, 350))


def test_vocabulary_search_after_index_rebuilds_agrees_with_exhaustive_search():
    vocabulary = Vocabulary(nndr=0.8, seed=3)
    words = descriptors(3 * REBUILD_PENDING)
    ids = np.concatenate([vocabulary.add_location(location, chunk) for location, chunk in enumerate(np.split(words, 6))])
    queries = flip_bits(words[::7], 12)
    # Oracle: brute-force ratio test over each word's creating descriptor.
    word_ids, first = np.unique(ids, return_index=True)
    pairs = cv2.BFMatcher(cv2.NORM_HAMMING).knnMatch(queries, words[first], k=2)
    oracle = np.array([word_ids[a.trainIdx] if a.distance < 0.8 * b.distance else -1 for a, b in pairs])
    assert (vocabulary.quantize(queries) == oracle).mean() > 0.95   # LSH is approximate


def test_words_of_long_term_memory_are_not_searched_until_retrieved():
    vocabulary = Vocabulary(nndr=0.8)
    base = descriptors(100)
    words = vocabulary.add_location(0, base)
    vocabulary.add_location(1, descriptors(100))
    vocabulary.unindex(0, words)
    assert (vocabulary.quantize(base) == -1).all() and len(vocabulary) == 100
    vocabulary.index(0, words)
    assert np.array_equal(vocabulary.quantize(base), words)


def vocabulary_of(words: int) -> Vocabulary:
    """A vocabulary holding ``words`` words that no location holds yet."""
    vocabulary = Vocabulary(nndr=0.8)
    vocabulary.unindex(-1, vocabulary.add_location(-1, descriptors(words)))
    return vocabulary


def test_tf_idf_scores_by_hand():
    vocabulary = vocabulary_of(8)
    vocabulary.index(10, np.array([0, 0, 1, 2]))
    vocabulary.index(11, np.array([1, 3]))
    vocabulary.index(12, np.array([4, 5]))
    scores = vocabulary.scores(np.array([0, 1, 7]), [10, 11, 12])
    # word 0: in 1 of 3 locations, word 1: in 2 of 3.
    assert scores == pytest.approx([2 / 4 * np.log(3) + 1 / 4 * np.log(1.5), 1 / 2 * np.log(1.5), 0.0])


def test_likelihood_follows_rtabmap_normalisation():
    scores = np.array([1.0, 1.0, 1.0, 5.0])
    mean, std = scores.mean(), scores.std()
    values, new_place = likelihood(scores)
    assert values == pytest.approx([1, 1, 1, (5 - std) / mean])
    assert new_place == pytest.approx(mean / std + 1)
    assert likelihood(np.zeros(3))[1] == 1.0


def test_bayes_filter_belief_builds_on_a_revisited_place_and_stays_on_new_place_otherwise():
    ids = list(range(20))
    chain, positions = np.zeros(20, int), np.arange(20)
    flat = BayesFilter()
    for _ in range(3):
        posterior = flat.update(ids, positions, chain, np.ones(20), 1.0)
    assert posterior[NEW_PLACE] == pytest.approx(max(posterior.values()))
    assert sum(posterior.values()) == pytest.approx(1.0)
    revisit = BayesFilter()
    strong = np.ones(20)
    strong[7] = 30.0
    posteriors = [revisit.update(ids, positions, chain, strong, 2.0)[7] for _ in range(3)]
    assert posteriors[0] < posteriors[1] < posteriors[2] and posteriors[2] > 0.11
    assert max(revisit.posterior, key=revisit.posterior.get) == 7


def test_similarity_counts_shared_words_against_the_larger_location():
    assert similarity(np.array([1, 2, 2, 3]), np.array([2, 2, 3, 4, 5])) == pytest.approx(3 / 5)
    assert similarity(np.array([1]), np.array([], int)) == 0.0


def location(location_id: int, words: np.ndarray, weight: int = 0) -> Location:
    empty = np.zeros((0, 3))
    return Location(location_id, 0, location_id, float(location_id), np.eye(4), np.zeros((0, 2)),
                    np.zeros((0, 32), np.uint8), empty, words, empty, np.zeros((0, 3), np.uint8), weight)


def test_memory_moves_least_weighted_oldest_to_ltm_and_retrieves_graph_neighbours():
    vocabulary = vocabulary_of(8)
    memory = Memory(vocabulary, stm_size=2)
    for i in range(8):
        words = np.array([i])
        vocabulary.index(i, words)
        memory.add(location(i, words, weight=3 if i == 1 else 0))
        if i:
            memory.link(i - 1, i)
    assert list(memory.stm) == [6, 7] and memory.wm == [0, 1, 2, 3, 4, 5]
    moved = memory.transfer(limit=3, protected={2})
    assert moved == [0, 3, 4] and memory.wm == [1, 2, 5] and memory.ltm == {0, 3, 4}
    assert vocabulary.scores(np.array([0, 3]), [0, 3]).tolist() == [0.0, 0.0]
    assert memory.retrieve(around=2, count=1) == [3]
    assert memory.wm == [1, 2, 3, 5] and vocabulary.scores(np.array([3]), [3])[0] > 0


def chain_graph(drift: float, max_error: float = 3.0) -> LocationGraph:
    """Ten locations on a circle whose odometry accumulates ``drift`` metres per link."""
    graph = LocationGraph(iterations=50, max_error=max_error)
    for i in range(10):
        angle = 2 * np.pi * i / 10
        truth = make_pose(exp_so3([0, angle, 0]), [np.sin(angle), 0, np.cos(angle)])
        graph.add_location(i, 0, truth @ make_pose(np.eye(3), [drift * i, 0, 0]), variance=1e-4)
    return graph


def test_a_consistent_loop_closure_is_accepted_and_pulls_the_chain_together():
    graph = chain_graph(drift=0.002)
    truth_9 = make_pose(exp_so3([0, 2 * np.pi * 0.9, 0]), [np.sin(2 * np.pi * 0.9), 0, np.cos(2 * np.pi * 0.9)])
    truth_0 = make_pose(np.eye(3), [0, 0, 1])
    before = np.linalg.norm(graph.poses[9][:3, 3] - truth_9[:3, 3])
    outcome = graph.close_loop(0, 9, invert(truth_0) @ truth_9, variance=1e-4)
    assert outcome.accepted and outcome.error_after < outcome.error_before
    assert np.linalg.norm(graph.poses[9][:3, 3] - truth_9[:3, 3]) < before / 2


def test_a_loop_closure_the_graph_cannot_absorb_is_rejected_and_undone():
    graph = chain_graph(drift=0.0)
    poses = {i: p.copy() for i, p in graph.poses.items()}
    wrong = make_pose(np.eye(3), [1.0, 0, 0])
    outcome = graph.close_loop(0, 5, wrong, variance=1e-4)
    assert not outcome.accepted and outcome.reason.startswith("optimisation error")
    assert float(outcome.reason.split()[2]) > 3.0
    assert len(graph.pose_graph.edges) == 9
    assert all(np.array_equal(graph.poses[i], poses[i]) for i in poses)


def test_a_closure_between_sessions_joins_the_newer_map_to_the_older():
    graph = LocationGraph(iterations=20, max_error=3.0)
    graph.add_location(0, 0, np.eye(4), 1e-4)
    graph.add_location(1, 0, make_pose(np.eye(3), [1.0, 0, 0]), 1e-4)
    graph.add_location(2, 1, np.eye(4), 0.0)            # odometry reset: a new session at its own origin
    graph.add_location(3, 1, make_pose(np.eye(3), [0, 0, 0.5]), 1e-4)
    assert graph.map_of(2) != graph.map_of(0)
    outcome = graph.close_loop(1, 2, make_pose(np.eye(3), [0.2, 0, 0]), 1e-4)
    assert outcome.accepted and graph.map_of(3) == graph.map_of(0)
    assert np.allclose(graph.poses[3][:3, 3], [1.2, 0, 0.5])
    assert set(graph.pose_graph.priors) == {0}


def test_registration_variance_is_the_median_squared_residual_ignoring_missing_depth():
    reference = np.zeros((4, 3))
    registered = np.array([[0.01, 0, 0], [0, 0.02, 0], [0, 0, 0.03], [np.nan, 0, 0]])
    assert registration_variance(reference, registered) == pytest.approx(0.02 ** 2)


@pytest.mark.parametrize("assignment, message", [
    ("Odom/ResetCountdown=two", "parameter Odom/ResetCountdown expects an integer"),
    ("Kp/DetectorStrategy=7", "parameter Kp/DetectorStrategy must be one of 6, 8"),
])
def test_bad_rtabmap_parameters_are_one_line_cli_errors(assignment, message, tmp_path, capsys):
    from viewer_slam.cli import main

    code = main(["record", str(tmp_path), "--pipeline", "rtabmap", "--param", assignment,
                 "--out", str(tmp_path / "run.rrd")])
    error = capsys.readouterr().err.strip()
    assert code == 2 and error.startswith("viewslam: error:") and message in error and "\n" not in error
