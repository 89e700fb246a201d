"""RTAB-Map building blocks against hand-computed values and exhaustive oracles."""

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from viewer_slam.dataset.frame import Frame
from viewer_slam.frontend.features import (
    SMOOTHING_DEPTH_ERROR_RATIO,
    SMOOTHING_OFFSETS,
    SMOOTHING_WEIGHTS,
    FeatureExtractor,
    Features,
    smoothed_depth,
)
from viewer_slam.geometry.camera import Camera
from viewer_slam.geometry.se3 import invert, make_pose, transform_points
from viewer_slam.pipelines.events import GraphEdge
from viewer_slam.pipelines.params import apply_overrides, resolve_params
from viewer_slam.pipelines.rtabmap import PIPELINE, RtabmapParams
from viewer_slam.pipelines.rtabmap import pipeline as rtabmap_pipeline
from viewer_slam.pipelines.rtabmap.bayes import (
    PREDICTION_LC,
    VIRTUAL_PLACE,
    BayesFilter,
    Hypothesis,
    adjusted_likelihood,
    highest_hypothesis,
    prediction_matrix,
)
from viewer_slam.pipelines.rtabmap.correspondences import BRUTE_FORCE, KD_TREE, TreeSeeds, word_matches
from viewer_slam.pipelines.rtabmap.graph import LocationGraph, Variance, registration_variance
from viewer_slam.pipelines.rtabmap.loop_closure import (
    Registration,
    proximity_candidates,
    proximity_paths,
    too_large_rotation,
)
from viewer_slam.pipelines.rtabmap.memory import Link, Location, Memory, similarity
from viewer_slam.pipelines.rtabmap.odometry import FrameToMapOdometry, LocalMap, motion_over, velocity_of
from viewer_slam.pipelines.rtabmap.vocabulary import REBUILD_PENDING, Vocabulary
from viewer_slam.pipelines.stopwatch import Stopwatch

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
    assert (defaults.loop_threshold, defaults.stm_size, defaults.local_map_size, defaults.min_inliers) == (
        0.11,
        10,
        2000,
        20,
    )
    assert PIPELINE.name == "rtabmap" and PIPELINE.Params is RtabmapParams


GUIDE_CAMERA = Camera(500.0, 500.0, 320.0, 240.0, 640, 480)


def guided_odometry(pixels: np.ndarray, map_descriptors: np.ndarray, **overrides) -> FrameToMapOdometry:
    """An odometry whose local map holds points 2 m in front of the identity pose at ``pixels``."""
    odometry = FrameToMapOdometry(GUIDE_CAMERA, apply_overrides(RtabmapParams(), overrides, "test"))
    odometry.map.add(
        GUIDE_CAMERA.backproject(pixels, np.full(len(pixels), 2.0)),
        map_descriptors,
        0,
        [(0, u, v, 2.0) for u, v in pixels],
    )
    return odometry


def corners(pixels, corner_descriptors) -> Features:
    pixels = np.asarray(pixels, np.float32)
    return Features(pixels, corner_descriptors, np.ones(len(pixels)), np.full((len(pixels), 3), np.nan), True)


def test_guided_matching_each_projected_point_in_word_order_takes_a_corner_not_yet_taken():
    words = descriptors(4)
    # Words 0 and 1 project 4 px apart with corner 0 alone near them. It is word 1's twin, yet
    # word 0, first in word order, takes it: a lone candidate needs no test. Word 2 projects
    # off the image (x = -3), next to its twin corner 1; word 3 30 px from its twin corner 2.
    odometry = guided_odometry(np.array([[100.0, 100.0], [104.0, 100.0], [-3.0, 300.0], [400.0, 300.0]]), words)
    frame = corners([[102.0, 100.0], [1.0, 300.0], [430.0, 300.0]], np.vstack([words[1], words[2], words[3]]))
    feature_index, map_index, projected = odometry.guided_matches(frame, np.eye(4))
    assert list(zip(feature_index.tolist(), map_index.tolist())) == [(0, 0), (2, 3)]
    # RegistrationVis's projectedIDs: in the image with a corner within 40 px (word 2 is off it)
    assert projected.tolist() == [0, 1, 3]


def test_guided_matching_to_projection_drops_a_map_point_two_corners_picked():
    words = descriptors(2)
    odometry = guided_odometry(
        np.array([[100.0, 100.0], [300.0, 200.0]]), words, **{"Vis/CorGuessMatchToProjection": True}
    )
    # corners 0 and 1 both have only word 0 within 40 px; corner 2 only word 1
    frame = corners([[95.0, 100.0], [110.0, 105.0], [305.0, 190.0]], np.vstack([words[0], words[0], words[1]]))
    feature_index, map_index, _ = odometry.guided_matches(frame, np.eye(4))
    assert feature_index.tolist() == [2] and map_index.tolist() == [1]


def test_guided_matching_ratio_test_drops_ambiguous_corners():
    twin = descriptors(1)
    odometry = guided_odometry(np.array([[50.0, 50.0]]), twin)
    # two corners 4 bits from the word, 2 and 5 px from its projection: 4 < 0.8 * 4 fails
    frame = corners([[52.0, 50.0], [55.0, 50.0]], flip_bits(np.vstack([twin, twin]), 4))
    frame.descriptors[1] = frame.descriptors[0]
    assert len(odometry.guided_matches(frame, np.eye(4))[0]) == 0


def five_key_frames_of_ten_points() -> LocalMap:
    """Points 10k..10k+9 added by key frame k, each point's x its index."""
    local_map = LocalMap()
    for frame in range(5):
        local_map.add(
            np.c_[np.arange(10 * frame, 10 * frame + 10), np.zeros((10, 2))],
            descriptors(10),
            frame,
            [(frame, float(i), 0.0, 1.0) for i in range(10)],
        )
    return local_map


def test_local_map_cap_removes_outliers_then_the_previous_key_frames_projected_points_then_the_oldest():
    local_map = five_key_frames_of_ten_points()
    # key frame 7 observes point 0 and point 10
    local_map.refer(np.array([0, 10]), [(7, 0.0, 0.0, 1.0), (7, 1.0, 0.0, 1.0)])
    # OdometryF2M: the matched words 12 and 35 that are not inliers go first, then the
    # previous key frame's (4) words 41 and 43 projected near a corner, then the oldest that
    # are not inliers (2 and 5 are) until 38 are left: 0, 1, 3, 4, 6, 7, 8, 9.
    local_map.cap(38, np.array([12, 35, 41, 43]), np.array([2, 5, 11, 42]), added=10)
    removed = sorted(set(range(50)) - set(local_map.points[:, 0].astype(int).tolist()))
    assert removed == [0, 1, 3, 4, 6, 7, 8, 9, 12, 35, 41, 43]
    assert local_map.added_on.tolist() == [0] * 2 + [1] * 9 + [2] * 10 + [3] * 9 + [4] * 8
    assert [references[0][0] for references in local_map.references] == local_map.added_on.tolist()
    # the observations of the removed points are gone with them, point 0's by key frame 7 too
    assert dict(local_map.referenced) == {0: 2, 1: 9, 2: 10, 3: 9, 4: 8, 7: 1}


def test_local_map_cap_keeps_every_new_point_of_a_key_frame_larger_than_the_map():
    local_map = five_key_frames_of_ten_points()
    # 30 points may stay, but the key frame just added 40: OdometryF2M stops removing once
    # the map is one point below that, 39 (the eleven oldest go)
    local_map.cap(30, np.zeros(0, int), np.zeros(0, int), added=40)
    assert local_map.points[:, 0].astype(int).tolist() == list(range(11, 50))


def add_all(vocabulary: Vocabulary, location: int, rows: np.ndarray) -> np.ndarray:
    """Add a location whose every feature is quantised to a word."""
    return vocabulary.add_location(location, rows, np.arange(len(rows)))


def test_vocabulary_reuses_words_and_creates_new_ones():
    vocabulary = Vocabulary(nndr=0.8)
    base = descriptors(300)
    first = add_all(vocabulary, 0, base)
    assert sorted(first.tolist()) == list(range(300)) and len(vocabulary) == 300
    again = add_all(vocabulary, 1, np.vstack([flip_bits(base[:200], 10), descriptors(50)]))
    assert np.array_equal(again[:200], first[:200])
    assert set(again[200:].tolist()) == set(range(300, 350))


def test_vocabulary_search_after_index_rebuilds_agrees_with_exhaustive_search():
    vocabulary = Vocabulary(nndr=0.8, seed=3)
    words = descriptors(3 * REBUILD_PENDING)
    ids = np.concatenate([add_all(vocabulary, location, chunk) for location, chunk in enumerate(np.split(words, 6))])
    queries = flip_bits(words[::7], 12)
    # Oracle: brute-force ratio test over each word's creating descriptor.
    word_ids, first = np.unique(ids, return_index=True)
    pairs = cv2.BFMatcher(cv2.NORM_HAMMING).knnMatch(queries, words[first], k=2)
    oracle = np.array([word_ids[a.trainIdx] if a.distance < 0.8 * b.distance else -1 for a, b in pairs])
    assert (vocabulary.quantize(queries) == oracle).mean() > 0.95  # LSH is approximate


def test_words_of_long_term_memory_are_not_searched_until_retrieved():
    vocabulary = Vocabulary(nndr=0.8)
    base = descriptors(100)
    words = add_all(vocabulary, 0, base)
    add_all(vocabulary, 1, descriptors(100))
    vocabulary.unindex(0, words)
    assert (vocabulary.quantize(base) == -1).all() and len(vocabulary) == 100
    vocabulary.index(0, words)
    assert np.array_equal(vocabulary.quantize(base), words)


def vocabulary_of(words: int) -> Vocabulary:
    """A vocabulary holding ``words`` words that no location holds yet."""
    vocabulary = Vocabulary(nndr=0.8)
    vocabulary.unindex(-1, add_all(vocabulary, -1, descriptors(words)))
    return vocabulary


def test_tf_idf_scores_by_hand():
    vocabulary = vocabulary_of(8)
    vocabulary.index(10, np.array([0, 0, 1, 2]))
    vocabulary.index(11, np.array([1, 3]))
    vocabulary.index(12, np.array([4, 5]))
    scores = vocabulary.scores(np.array([0, 1, 7]), [10, 11, 12])
    # Memory::computeLikelihood: word 0 is in 1 of 3 locations, word 1 in 2 of 3; idf in log10.
    assert scores == pytest.approx([2 / 4 * np.log10(3) + 1 / 4 * np.log10(1.5), 1 / 2 * np.log10(1.5), 0.0])


def test_a_location_with_fewer_words_than_half_the_mean_is_a_bad_signature():
    pipeline = PIPELINE(CAMERA, RtabmapParams())
    pipeline.vocabulary = vocabulary_of(8)
    for location_id, words in enumerate(([0, 1, 2, 3, 4, 5], [0, 1, 2], [3, 4, 5, 6])):
        pipeline.vocabulary.index(location_id, np.array(words))
    assert pipeline.vocabulary.mean_words_per_location() == 13 // 3  # 4: Kp/BadSignRatio 0.5 of it is 2
    keep = lambda count: len(pipeline._signature(view(scene(count), np.eye(4), descriptors(count))))  # noqa: E731
    assert (keep(1), keep(2), keep(600)) == (0, 2, 600)  # all of them kept, not only the words


def test_only_the_strongest_features_become_words_but_every_feature_counts_in_tf_idf():
    # Memory::createSignature quantises the Kp/MaxFeatures strongest features and keeps the
    # rest with no word; Memory::computeLikelihood divides by every feature the location holds
    # (getNi), and the mean words per location counts the dictionary's references only.
    vocabulary = vocabulary_of(0)
    rows = descriptors(6)
    words = vocabulary.add_location(10, rows, np.array([0, 2, 4]))
    assert (words[[1, 3, 5]] == -1).all() and len(set(words[[0, 2, 4]].tolist())) == 3
    vocabulary.index(11, np.array([words[0], -1]))
    assert vocabulary.mean_words_per_location() == 4 // 2
    scores = vocabulary.scores(np.array([words[2], -1]), [10, 11])
    assert scores == pytest.approx([1 / 6 * np.log10(2), 0.0])
    assert (vocabulary.quantize(rows[[1, 3, 5]]) == -1).all()


def test_likelihood_is_normalised_by_the_non_zero_scores_and_the_virtual_place_gets_mean_over_std_plus_one():
    # Non-zero scores 1, 1, 1, 1, 6: mean 2, sample std sqrt((4 * 1 + 16) / 4) = sqrt(5).
    values, virtual = adjusted_likelihood(np.array([0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 6.0]))
    std = np.sqrt(5.0)
    assert values == pytest.approx([1, 1, 1, 1, 1, 1, (6 - (std - 1e-4)) / 2])
    assert virtual == pytest.approx(2 / std + 1)


def test_virtual_place_gets_mean_over_std_plus_one_even_when_no_score_stands_out():
    # The original's debug log (rtabmap-rgbd_dataset --udebug, 360_kidnap seed 0 per frame, its
    # second Bayes update): "mean=0.021662, stdDev=0.003616, max=0.024219", so the two scores
    # are 0.024219 and 0.019105, neither above mean + std; then "Highest hypothesis=1,
    # value=0.076489", which only a virtual place likelihood of mean / std + 1 gives.
    scores = np.array([0.024219, 2 * 0.021662 - 0.024219])
    values, virtual = adjusted_likelihood(scores)
    assert values.tolist() == [1.0, 1.0]
    assert virtual == pytest.approx(0.021662 / 0.003616 + 1, rel=1e-3)
    bayes = BayesFilter()
    bayes.update([1], lambda location: {1: 0}, np.ones(1), 2.0)  # its first: one score, std 0
    chain = {1: {1: 0, 2: 1}, 2: {2: 0, 1: 1}}
    posterior = bayes.update([1, 2], chain.__getitem__, values, virtual)
    assert highest_hypothesis(posterior).value == pytest.approx(0.076489, rel=1e-3)


@pytest.mark.parametrize("scores", [[0.0, 3.0, 3.0], [0.0, 0.0, 0.0]])
def test_virtual_place_likelihood_is_two_when_no_score_stands_out(scores):
    values, virtual = adjusted_likelihood(np.array(scores))
    assert values.tolist() == [1.0, 1.0, 1.0] and virtual == 2.0


def test_hypothesis_is_the_best_location_valued_at_the_sum_of_loop_closure_probabilities():
    hypothesis = highest_hypothesis({VIRTUAL_PLACE: 0.5, 3: 0.2, 5: 0.2, 7: 0.1})
    assert hypothesis.location == 5 and hypothesis.value == pytest.approx(0.5)  # newest of the tied best
    assert highest_hypothesis({VIRTUAL_PLACE: 1.0, 3: 0.0}) is None


def chain_memory(count: int, stm_size: int = 0) -> Memory:
    """``count`` locations linked in a chain by odometry."""
    vocabulary = vocabulary_of(8)
    memory = Memory(vocabulary, stm_size=stm_size)
    for i in range(count):
        vocabulary.index(i, np.array([i % 8]))
        memory.add(location(i, np.array([i % 8])))
        if i:
            memory.link(i - 1, i, Link.NEIGHBOUR)
    return memory


def test_prediction_spreads_by_graph_margin_and_keeps_the_missing_share_on_the_location():
    memory = chain_memory(3)
    matrix = prediction_matrix([0, 1, 2], lambda i: memory.neighbours(i, len(PREDICTION_LC) - 1))
    # States: virtual place, 0, 1, 2. The virtual place keeps 0.9 and gives 0.1 / 3 to each.
    assert matrix[:, 0] == pytest.approx([0.9, 0.1 / 3, 0.1 / 3, 0.1 / 3])
    # End of the chain: itself 0.36, margin 1 0.30, margin 2 0.16 = 0.82; the 0.08 its absent
    # neighbours would get stays on it, so the column still sums to 1.
    assert matrix[:, 1] == pytest.approx([0.1, 0.36 + (sum(PREDICTION_LC) - 0.1 - 0.82), 0.30, 0.16])
    # Middle: 0.36 + 2 x 0.30 = 0.96 > 0.9, scaled down to 0.9.
    assert matrix[:, 2] == pytest.approx([0.1, 0.30 * 0.9 / 0.96, 0.36 * 0.9 / 0.96, 0.30 * 0.9 / 0.96])


def test_prediction_gives_locations_joined_by_a_loop_closure_the_same_margin():
    memory = chain_memory(3)
    memory.link(0, 2, Link.LOOP)
    matrix = prediction_matrix([0, 1, 2], lambda i: memory.neighbours(i, len(PREDICTION_LC) - 1))
    # 0 and 2 are one place: 0.36 each and 0.30 for 1 make 1.02, scaled to 0.9.
    expected = [0.1, 0.36 * 0.9 / 1.02, 0.30 * 0.9 / 1.02, 0.36 * 0.9 / 1.02]
    assert matrix[:, 1] == pytest.approx(expected) and matrix[:, 3] == pytest.approx(expected)


def test_bayes_update_multiplies_the_prediction_by_the_likelihood():
    memory = chain_memory(3)
    neighbours = lambda i: memory.neighbours(i, len(PREDICTION_LC) - 1)  # noqa: E731
    bayes = BayesFilter()
    first = bayes.update([0, 1, 2], neighbours, np.array([1.0, 4.0, 1.0]), 2.0)
    # BayesFilter::updatePosterior: the first update starts from 1 in every state, so the prior
    # is each row's sum of the prediction (columns checked above): the virtual place keeps 0.9
    # and gets 0.1 from each location, 1.2 in all, against 1 - 0.1 = 0.9 per location column.
    prior = prediction_matrix([0, 1, 2], neighbours).sum(axis=1)
    assert prior[0] == pytest.approx(0.9 + 3 * 0.1) and prior.sum() == pytest.approx(1 + 3 * 1)
    belief = prior * [2, 1, 4, 1]
    assert [first[k] for k in (VIRTUAL_PLACE, 0, 1, 2)] == pytest.approx(belief / belief.sum())
    prior = prediction_matrix([0, 1, 2], neighbours) @ (belief / belief.sum())
    second = bayes.update([0, 1, 2], neighbours, np.ones(3), 2.0)
    expected = prior * [2, 1, 1, 1]
    assert [second[k] for k in (VIRTUAL_PLACE, 0, 1, 2)] == pytest.approx(expected / expected.sum())


def test_graph_neighbours_count_margins_by_odometry_links_and_keep_loop_links_on_the_margin():
    memory = chain_memory(5)
    memory.link(0, 4, Link.LOOP)
    assert memory.neighbours(0, 3) == {0: 0, 4: 0, 1: 1, 3: 1, 2: 2}
    assert memory.neighbours(0, 3, loops_add_margin=True) == {0: 0, 1: 1, 4: 1, 2: 2, 3: 2}
    assert memory.neighbours(0, 2, follow_loops=False) == {0: 0, 1: 1}


def test_similarity_counts_shared_words_against_the_larger_location():
    assert similarity(np.array([1, 2, 2, 3]), np.array([2, 2, 3, 4, 5])) == pytest.approx(3 / 5)
    assert similarity(np.array([1]), np.array([], int)) == 0.0
    # Features with no word (-1) count in neither location (Signature::compareTo's invalid words).
    assert similarity(np.array([1, 2, -1, -1]), np.array([2, 3, -1])) == pytest.approx(1 / 2)


def location(location_id: int, words: np.ndarray, weight: int = 0) -> Location:
    empty = np.zeros((0, 3))
    return Location(
        location_id,
        0,
        location_id,
        float(location_id),
        np.eye(4),
        np.zeros((0, 2)),
        np.zeros((0, 32), np.uint8),
        empty,
        words,
        empty,
        np.zeros((0, 3), np.uint8),
        weight,
    )


def test_memory_moves_least_weighted_oldest_to_ltm_and_retrieves_graph_neighbours():
    vocabulary = vocabulary_of(8)
    memory = Memory(vocabulary, stm_size=2)
    for i in range(8):
        words = np.array([i])
        vocabulary.index(i, words)
        memory.add(location(i, words, weight=3 if i == 1 else 0))
        if i:
            memory.link(i - 1, i, Link.NEIGHBOUR)
    assert list(memory.stm) == [6, 7] and memory.wm == [0, 1, 2, 3, 4, 5]
    # 5 is linked to 6, in STM, and may not go; 1 is heavier than the rest.
    moved = memory.forget(3, protected={2})
    assert moved == [0, 3, 4] and memory.wm == [1, 2, 5] and memory.ltm == {0, 3, 4}
    assert vocabulary.scores(np.array([0, 3]), [0, 3]).tolist() == [0.0, 0.0]
    # Nearest first (2 itself, then 3 and 1, newest first), STM left out; the search may
    # enter two LTM locations (3 and 4), so 0 stays unknown.
    order, immune = memory.retrieval_order(2, ltm_budget=2)
    assert order == [2, 3, 1, 4, 5] and immune == {1, 2, 3, 4, 5}
    assert memory.retrieve(order, count=1) == [3]
    assert memory.wm == [1, 2, 3, 5] and vocabulary.scores(np.array([3]), [3])[0] > 0


def test_locations_newer_than_the_last_loop_closure_stay_while_fewer_than_the_recent_share():
    memory = chain_memory(21, stm_size=1)  # WM 0..19, STM 20
    memory.link(3, 17, Link.LOOP)  # last loop closure location: 17
    # Mem/RecentWmRatio 0.2 of 20 = 4; 17, 18, 19 are 3 (> 1 and < 4): kept with 17 itself.
    assert memory.removable(25, set()) == list(range(0, 17))
    memory.locations[0].weight = 1
    assert memory.removable(2, set()) == [1, 2]


CAMERA = Camera(fx=300.0, fy=300.0, cx=160.0, cy=120.0, width=320, height=240)


@pytest.mark.parametrize(
    "overrides, elapsed_ms, moved",
    [
        ({"Rtabmap/TimeThr": 50}, 80.0, [0, 1]),  # over time: (added 1) + 1 locations
        ({"Rtabmap/TimeThr": 50}, 20.0, []),
        ({"Rtabmap/MemoryThr": 5}, 0.0, [0, 1]),  # WM holds 7 > 5: again added + 1, not down to 5
        ({"Rtabmap/MemoryThr": 7}, 0.0, []),
    ],
)
def test_over_budget_an_update_transfers_one_more_location_than_it_added(overrides, elapsed_ms, moved):
    pipeline = PIPELINE(CAMERA, apply_overrides(RtabmapParams(), overrides, "test"))
    pipeline.memory = chain_memory(9, stm_size=2)  # WM 0..6, STM 7, 8
    pipeline._keep_budget(set(), 1, elapsed_ms)
    assert sorted(pipeline.memory.ltm) == moved


def view(points_world: np.ndarray, pose: np.ndarray, descriptors_: np.ndarray) -> Features:
    """The features a camera at ``pose`` sees of world points (all with depth)."""
    points = (invert(pose) @ np.c_[points_world, np.ones(len(points_world))].T).T[:, :3]
    pixels = points[:, :2] / points[:, 2:] * [CAMERA.fx, CAMERA.fy] + [CAMERA.cx, CAMERA.cy]
    return Features(pixels.astype(np.float32), descriptors_, np.ones(len(points)), points, True)


def scene(count: int = 300, rng=None) -> np.ndarray:
    rng = rng or np.random.default_rng(1)
    return np.c_[rng.uniform(-1.5, 1.5, count), rng.uniform(-1.0, 1.0, count), rng.uniform(2.0, 4.0, count)]


def test_a_guess_window_of_zero_registers_every_frame_against_the_whole_local_map(monkeypatch):
    """Vis/CorGuessWinSize 0 disables guided matching (RegistrationVis: only a window over 0
    uses the guess)."""
    world, words = scene(), descriptors(300, np.random.default_rng(2))
    odometry = FrameToMapOdometry(CAMERA, apply_overrides(RtabmapParams(), {"Vis/CorGuessWinSize": 0}, "test"))
    monkeypatch.setattr(odometry, "guided_matches", lambda *_: pytest.fail("guided matching with a window of 0"))
    for step in range(3):
        pose = make_pose(Rotation.from_rotvec([0, np.radians(step), 0]).as_matrix(), [0.01 * step, 0, 0])
        assert np.allclose(odometry.process(view(world, pose, words), step / 30).pose, pose, atol=1e-3)


def z_y_x(yaw: float, pitch: float, roll: float) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll), the convention of RTAB-Map's Euler angles."""
    return (
        Rotation.from_rotvec([0, 0, yaw]).as_matrix()
        @ Rotation.from_rotvec([0, pitch, 0]).as_matrix()
        @ Rotation.from_rotvec([roll, 0, 0]).as_matrix()
    )


def test_the_motion_guess_is_the_last_velocity_times_the_time_since_the_last_frame(monkeypatch):
    """Odometry::process: the last motion's translation and Euler angles over the time it
    took, times the time since; none before two frames were registered in a row."""
    angles = np.radians([1.0, -0.5, 0.25])
    motion = make_pose(z_y_x(*angles), [0.01, -0.004, 0.002])
    # over 0.04 s, then 0.06 s later: 1.5 times each translation and angle
    expected = make_pose(z_y_x(*1.5 * angles), [0.015, -0.006, 0.003])
    np.testing.assert_allclose(motion_over(velocity_of(motion, 0.04), 0.06), expected, atol=1e-12)

    world, words = scene(), descriptors(300, np.random.default_rng(2))
    # Reg/RepeatOnce off: its guided repeat of the map's second frame is not a motion guess.
    odometry = FrameToMapOdometry(CAMERA, apply_overrides(RtabmapParams(), {"Reg/RepeatOnce": False}, "test"))
    predicted, guided = [], odometry.guided_matches
    monkeypatch.setattr(
        odometry, "guided_matches", lambda features, pose: predicted.append(pose) or guided(features, pose)
    )
    odometry.process(view(world, np.eye(4), words), 0.0)
    assert np.allclose(odometry.process(view(world, motion, words), 0.04).pose, motion, atol=1e-6)
    assert predicted == []  # no velocity yet, no guess
    odometry.process(view(world, motion @ expected, words), 0.10)
    np.testing.assert_allclose(predicted, [motion @ expected], atol=1e-6)


def test_after_a_loss_odometry_registers_against_the_whole_local_map():
    world, words = scene(), descriptors(300, np.random.default_rng(2))
    odometry = FrameToMapOdometry(CAMERA, RtabmapParams())
    assert odometry.process(view(world, np.eye(4), words), 0 / 30).new_session
    blocked = odometry.process(view(world, np.eye(4), descriptors(300, np.random.default_rng(3))), 1 / 30)
    assert blocked.pose is None and odometry.velocity is None
    # The camera comes back 0.4 m and 15 degrees away: far outside the 40-pixel window
    # around the last pose, found by matching the whole map.
    moved = make_pose(Rotation.from_rotvec([0, np.radians(15), 0]).as_matrix(), [0.4, 0.1, 0.2])
    back = odometry.process(view(world, moved, words), 2 / 30)
    assert back.pose is not None and np.allclose(back.pose, moved, atol=1e-3) and not back.new_session


def test_a_registration_made_without_a_guess_is_redone_with_its_result_as_the_guess():
    """Registration::computeTransformationMod (Reg/RepeatOnce): after a loss the whole-map
    ratio test finds the 150 map points whose descriptors have a twin elsewhere in the map
    ambiguous; redone with its own result as the guess, each projected map point takes its
    corner in the 40-pixel window, where the twin (behind the camera) does not compete: every
    map point whose projection falls in the image is then an inlier."""
    rng = np.random.default_rng(5)
    world, words = scene(), descriptors(300, rng)
    seen = flip_bits(words, 10, rng)
    twins = flip_bits(seen[:150], 10, rng)  # as far from what is seen
    moved = make_pose(Rotation.from_rotvec([0, np.radians(3), 0]).as_matrix(), [0.05, 0, 0])
    pixels = view(world, moved, seen).keypoints
    in_image = int(np.all((pixels >= 0) & (pixels <= [CAMERA.width - 1, CAMERA.height - 1]), axis=1).sum())
    for repeat, inliers in ((True, in_image), (False, 150)):
        odometry = FrameToMapOdometry(
            CAMERA, apply_overrides(RtabmapParams(), {"Reg/RepeatOnce": repeat, "OdomF2M/BundleAdjustment": 0}, "test")
        )
        odometry.process(view(world, np.eye(4), words), 0 / 30)
        odometry.map.add(world[:150] * [1, 1, -1], twins, 0, [(0, 0.0, 0.0, 1.0)] * 150)
        assert odometry.process(view(world, np.eye(4), descriptors(300, rng)), 1 / 30).pose is None
        back = odometry.process(view(world, moved, seen), 2 / 30)
        assert back.inliers == inliers and np.allclose(back.pose, moved, atol=1e-3)


@pytest.mark.parametrize("reprojection_error", [2.0, 1.5, 1.0])
def test_pnp_counts_a_match_as_an_inlier_within_the_square_of_vis_pnp_reproj_error(reprojection_error):
    """RTAB-Map's PnP RANSAC (the OpenCV 3.0 copy in corelib/src/opencv/solvepnp.cpp) takes
    each match's plain pixel distance as its error and compares it with the threshold
    squared: under the pose it returns (the best six-point sample's), a match is an inlier
    exactly when it reprojects within Vis/PnPReprojError² px, so at 2 matches 3 px off count
    (3 <= 4)."""
    rng = np.random.default_rng(4)
    world = np.c_[rng.uniform(-0.9, 0.9, 300), rng.uniform(-0.6, 0.6, 300), rng.uniform(2.0, 4.0, 300)]
    words = descriptors(300, rng)
    odometry = FrameToMapOdometry(
        CAMERA,
        apply_overrides(
            RtabmapParams(),
            {"Vis/PnPReprojError": reprojection_error, "OdomF2M/BundleAdjustment": 0, "Vis/PnPRefineIterations": 0},
            "test",
        ),
    )
    odometry.process(view(world, np.eye(4), words), 0 / 30)
    moved = make_pose(Rotation.from_rotvec([0, np.radians(1), 0]).as_matrix(), [0.02, 0, 0])
    seen = view(world, moved, words)
    directions = rng.uniform(0, 2 * np.pi, 300)
    off = np.repeat([0.0, 3.0, 6.0], [200, 50, 50])
    shifted = Features(
        (seen.keypoints + off[:, None] * np.c_[np.cos(directions), np.sin(directions)]).astype(np.float32),
        seen.descriptors,
        seen.responses,
        seen.points,
        True,
    )
    result = odometry.process(shifted, 1 / 30)
    reprojected = CAMERA.project(transform_points(invert(result.pose), odometry.map.points[result.map_index]))
    distance = np.linalg.norm(reprojected - shifted.keypoints[result.feature_index], axis=1)
    assert np.array_equal(result.match_inliers, distance <= reprojection_error**2 + 1e-4)
    counted = off[result.feature_index[result.match_inliers]]
    assert (counted == 0).sum() >= 190
    assert (counted == 3).sum() >= (40 if reprojection_error == 2.0 else 0)


def test_a_repeated_registration_goes_on_without_the_features_that_took_one_map_word():
    """RegistrationVis without a guess keeps of the frame only the word ids that occur once:
    two features whose nearest map word is the same (2 and 3 bits from it, about 128 from
    every other) both leave the frame; a feature 1 bit from another word stays, as do one
    that passes no ratio test (a new word) and an exact copy of a third word."""
    rng = np.random.default_rng(7)
    words = descriptors(5, rng)
    frame = np.concatenate(
        [
            flip_bits(words[:1], 2, rng),
            flip_bits(words[:1], 3, rng),
            flip_bits(words[1:2], 1, rng),
            descriptors(1, rng),
            words[2:3],
        ]
    )
    for nn_type in (KD_TREE, BRUTE_FORCE):
        matches = word_matches(frame, words, 0.8, nn_type, TreeSeeds(0))
        assert matches.kept.tolist() == [2, 3, 4]
        assert list(zip(matches.query.tolist(), matches.train.tolist())) == [(2, 1), (4, 2)]


def test_the_approximate_search_is_flanns_and_follows_the_runs_seed():
    """Vis/CorNNType 1 asks FLANN's randomised k-d trees, seeded before every build from the
    run's seed: the same seed gives the same matches whatever the C library's generator did in
    between, the next build of the same run other trees (RTAB-Map draws each build's from
    std::random_device); on descriptors with no near duplicate the nearest word is the exact
    one wherever the ratio test is clear, whichever the trees."""
    rng = np.random.default_rng(11)
    words = descriptors(2000, rng)
    frame = np.concatenate([flip_bits(words[:300], 8, rng), descriptors(600, rng)])
    pairs = lambda matches: set(zip(matches.query.tolist(), matches.train.tolist()))  # noqa: E731
    run = TreeSeeds(0)
    first, second = word_matches(frame, words, 0.8, KD_TREE, run), word_matches(frame, words, 0.8, KD_TREE, run)
    cv2.randu(np.zeros((4, 4)), 0, 1)
    again = TreeSeeds(0)
    assert pairs(word_matches(frame, words, 0.8, KD_TREE, again)) == pairs(first)
    assert pairs(word_matches(frame, words, 0.8, KD_TREE, again)) == pairs(second)
    assert pairs(first) != pairs(second)  # 600 unrelated descriptors: ratio tests the trees decide
    exact = word_matches(frame, words, 0.8, BRUTE_FORCE, run)
    assert pairs(exact) <= set(zip(range(300), range(300)))
    assert len(exact.query) >= 290  # 8 of 256 bits off: ~128 from every other word
    for approximate in (first, second):
        assert len(pairs(approximate) & pairs(exact)) >= 0.9 * len(exact.query)


def test_reset_countdown_starts_a_new_map_at_the_last_good_pose():
    world, words = scene(), descriptors(300, np.random.default_rng(2))
    odometry = FrameToMapOdometry(CAMERA, apply_overrides(RtabmapParams(), {"Odom/ResetCountdown": 2}, "test"))
    moved = make_pose(Rotation.from_rotvec([0, np.radians(2), 0]).as_matrix(), [0.02, 0, 0.01])
    odometry.process(view(world, np.eye(4), words), 0 / 30)
    assert np.allclose(odometry.process(view(world, moved, words), 1 / 30).pose, moved, atol=1e-3)
    other = np.random.default_rng(4)
    assert odometry.process(view(scene(rng=other), moved, descriptors(300, other)), 2 / 30).pose is None
    restart = odometry.process(view(scene(rng=other), moved, descriptors(300, other)), 3 / 30)
    assert restart.new_session and restart.reset and np.allclose(restart.pose, moved, atol=1e-3)


UNGUIDED = {"Reg/RepeatOnce": False}  # the map's second frame registered by descriptor alone, not redone guided


def test_bundle_adjustment_drops_inliers_whose_depth_disagrees_and_key_frames_record_their_observations():
    world, words = scene(), descriptors(300, np.random.default_rng(2))
    odometry = FrameToMapOdometry(CAMERA, apply_overrides(RtabmapParams(), UNGUIDED, "test"))
    odometry.process(view(world, np.eye(4), words), 0 / 30)
    moved = make_pose(Rotation.from_rotvec([0, np.radians(2), 0]).as_matrix(), [0.02, 0, 0.01])
    features = view(world, moved, words)
    # 30 depths moved along their rays by 8 px of disparity on the fake g2o/Baseline of
    # 7.5 cm: PnP, which only reprojects, takes them; in the bundle each point splits the
    # conflict between its two stereo edges, 4 px each, chi2 16 > g2o/RobustKernelDelta 8.
    baseline_px = CAMERA.fx * 0.075
    depth = features.points[:30, 2]
    features.points[:30] *= (baseline_px / (baseline_px / depth + 8.0) / depth)[:, None]
    result = odometry.process(features, 1 / 30)
    assert np.allclose(result.pose, moved, atol=1e-3)
    assert result.inliers == 270
    assert not result.match_inliers[result.feature_index < 30].any()
    # 270 inliers are over Odom/VisKeyFrameThr 150: not a key frame, the map is as it was.
    assert list(odometry.key_frames.poses) == [1] and all(len(r) == 1 for r in odometry.map.references)
    # A view of 140 points is a key frame: every map point it matched gains its observation
    # (a lone corner near another point's projection is a match too, but no inlier).
    key_frame = odometry.process(view(world[100:240], moved, words[100:240]), 2 / 30)
    registered = key_frame.map_index[key_frame.match_inliers]
    assert key_frame.inliers > 100 and set(registered) <= set(range(100, 240))
    assert list(odometry.key_frames.poses) == [1, 3]
    matched = set(key_frame.map_index.tolist())
    assert [len(r) for r in odometry.map.references[:300]] == [1 + (i in matched) for i in range(300)]


@pytest.mark.parametrize(("repeat_once", "guided_registrations"), [(True, 1), (False, 0)])
def test_a_registration_repeated_once_is_bundle_adjusted_once_after_its_repeat(
    monkeypatch, repeat_once, guided_registrations
):
    """Registration::computeTransformationMod makes the Reg/RepeatOnce repeat of a registration
    without a guess before it returns, and OdometryF2M bundle-adjusts only what it returns: the
    map's second frame (no velocity yet) is adjusted once, whether repeated or not."""
    world, words = scene(), descriptors(300, np.random.default_rng(2))
    moved = make_pose(Rotation.from_rotvec([0, np.radians(2), 0]).as_matrix(), [0.02, 0, 0.01])
    odometry = FrameToMapOdometry(CAMERA, apply_overrides(RtabmapParams(), {"Reg/RepeatOnce": repeat_once}, "test"))
    adjusted, guides = [], []
    bundle, guided = odometry._bundle_adjust, odometry.guided_matches
    monkeypatch.setattr(odometry, "_bundle_adjust", lambda *args: adjusted.append(args) or bundle(*args))
    monkeypatch.setattr(odometry, "guided_matches", lambda f, pose: guides.append(pose) or guided(f, pose))
    odometry.process(view(world, np.eye(4), words), 0 / 30)
    result = odometry.process(view(world, moved, words), 1 / 30)
    assert np.allclose(result.pose, moved, atol=1e-3)
    assert len(guides) == guided_registrations and len(adjusted) == 1


def test_a_key_frame_observes_every_matched_map_point_and_adds_only_the_features_that_matched_none():
    """OdometryF2M: a matched feature carries its map word's id, inlier or not."""
    world, words = scene(), descriptors(300, np.random.default_rng(2))
    odometry = FrameToMapOdometry(CAMERA, apply_overrides(RtabmapParams(), UNGUIDED, "test"))
    odometry.process(view(world, np.eye(4), words), 0 / 30)
    moved = make_pose(Rotation.from_rotvec([0, np.radians(2), 0]).as_matrix(), [0.02, 0, 0.01])
    new_rng = np.random.default_rng(5)
    seen = view(np.r_[world[100:240], scene(30, new_rng)], moved, np.r_[words[100:240], descriptors(30, new_rng)])
    seen.keypoints[:20, 0] += 12.0  # map points 100..119 matched 12 px off: outliers of PnP
    result = odometry.process(seen, 1 / 30)
    matched = dict(zip(result.feature_index.tolist(), result.match_inliers.tolist()))
    assert all(i in matched and not matched[i] for i in range(20)) and result.inliers <= 150  # a key frame
    assert [len(r) for r in odometry.map.references[:300]] == [1 + (100 <= i < 240) for i in range(300)]
    assert len(odometry.map) == 300 + 30


def chain_graph(drift: float, max_error: float = 3.0) -> LocationGraph:
    """Ten locations on a circle whose odometry accumulates ``drift`` metres per link."""
    graph = LocationGraph(iterations=50, max_error=max_error)
    for i in range(10):
        angle = 2 * np.pi * i / 10
        truth = make_pose(Rotation.from_rotvec([0, angle, 0]).as_matrix(), [np.sin(angle), 0, np.cos(angle)])
        graph.add_location(i, 0, truth @ make_pose(np.eye(3), [drift * i, 0, 0]), variance=Variance(1e-4, 1e-4))
    return graph


def test_a_consistent_loop_closure_is_accepted_and_pulls_the_chain_together():
    graph = chain_graph(drift=0.002)
    truth_9 = make_pose(
        Rotation.from_rotvec([0, 2 * np.pi * 0.9, 0]).as_matrix(), [np.sin(2 * np.pi * 0.9), 0, np.cos(2 * np.pi * 0.9)]
    )
    truth_0 = make_pose(np.eye(3), [0, 0, 1])
    before = np.linalg.norm(graph.poses[9][:3, 3] - truth_9[:3, 3])
    outcome = graph.close_loops([(0, 9, invert(truth_0) @ truth_9, Variance(1e-4, 1e-4))])[0]
    assert outcome.accepted and outcome.error_after < outcome.error_before
    assert np.linalg.norm(graph.poses[9][:3, 3] - truth_9[:3, 3]) < before / 2


def test_a_loop_closure_the_graph_cannot_absorb_is_rejected_and_undone():
    graph = chain_graph(drift=0.0)
    poses = {i: p.copy() for i, p in graph.poses.items()}
    wrong = make_pose(np.eye(3), [1.0, 0, 0])
    outcome = graph.close_loops([(0, 5, wrong, Variance(1e-4, 1e-4))])[0]
    assert not outcome.accepted and outcome.reason.startswith("optimisation error")
    assert float(outcome.reason.split()[2]) > 3.0
    assert len(graph.pose_graph.edges) == 9
    assert all(np.array_equal(graph.poses[i], poses[i]) for i in poses)


@pytest.mark.parametrize("with_wrong", [False, True])
def test_an_updates_links_are_kept_or_rejected_together(with_wrong):
    """Rtabmap::process optimises once with all the links of an update and, when a link of the
    graph then disagrees by more than RGBD/OptimizeMaxError, rejects all of them ("Rejecting all
    added loop closures ... in this iteration"): a consistent link goes with a wrong one."""
    graph = chain_graph(drift=0.0)
    poses = {i: p.copy() for i, p in graph.poses.items()}
    right = invert(poses[0]) @ poses[9]
    links = [(0, 9, right, Variance(1e-4, 1e-4))]
    if with_wrong:
        links.append((0, 5, make_pose(np.eye(3), [1.0, 0, 0]), Variance(1e-4, 1e-4)))
    outcomes = graph.close_loops(links)
    assert all(outcome.accepted != with_wrong for outcome in outcomes)
    assert len(graph.pose_graph.edges) == 9 + (0 if with_wrong else 1)
    if with_wrong:
        assert all(np.array_equal(graph.poses[i], poses[i]) for i in poses)


def test_a_closure_between_sessions_joins_the_newer_map_to_the_older():
    graph = LocationGraph(iterations=20, max_error=3.0)
    graph.add_location(0, 0, np.eye(4), Variance(1e-4, 1e-4))
    graph.add_location(1, 0, make_pose(np.eye(3), [1.0, 0, 0]), Variance(1e-4, 1e-4))
    graph.add_location(2, 1, np.eye(4), Variance())  # odometry reset: a new session at its own origin
    graph.add_location(3, 1, make_pose(np.eye(3), [0, 0, 0.5]), Variance(1e-4, 1e-4))
    assert graph.map_of(2) != graph.map_of(0)
    outcome = graph.close_loops([(1, 2, make_pose(np.eye(3), [0.2, 0, 0]), Variance(1e-4, 1e-4))])[0]
    assert outcome.accepted and graph.map_of(3) == graph.map_of(0)
    assert np.allclose(graph.poses[3][:3, 3], [1.2, 0, 0.5])
    assert set(graph.pose_graph.priors) == {0}


@pytest.mark.parametrize(
    "axis, degrees, rejected",
    [
        ([0, -1, 0], 100, True),  # about the camera's up axis (optical -y): yaw 100 degrees
        ([0, -1, 0], 80, False),
        ([-1, 0, 0], 95, True),  # about the camera's left axis: pitch beyond 90 degrees
        ([0, 0, 1], 150, False),  # about the optical axis: roll, not checked
    ],
)
def test_a_loop_closure_turning_more_than_90_degrees_in_pitch_or_yaw_is_not_believed(axis, degrees, rejected):
    relative = make_pose(Rotation.from_rotvec(np.radians(degrees) * np.array(axis, float)).as_matrix(), [0.1, 0, 0])
    assert too_large_rotation(relative) == rejected


def test_keypoint_depth_is_smoothed_over_the_neighbours_within_2_percent_as_util2d_getdepth():
    """Weights 4 (centre), 2 (edge), 1 (corner); 1.50 (49 cm off), 1.03 (3 cm off) and 0 (missing)
    are left out: (4 x 1.00 + 2 x 1.01 + 2 x 1.01 + 0.99 + 1.00 + 1.015) / (4 + 2 + 2 + 1 + 1 + 1)."""
    depth = np.zeros((5, 5), np.float32)
    depth[1:4, 1:4] = [[0.99, 1.01, 1.00], [1.50, 1.00, 1.01], [1.03, 0.00, 1.015]]
    expected = (4 * 1.00 + 2 * 1.01 + 2 * 1.01 + 0.99 + 1.00 + 1.015) / 11
    assert smoothed_depth(depth, np.array([2]), np.array([2]))[0] == pytest.approx(expected, abs=1e-6)


def test_the_neighbours_counted_in_the_smoothing_are_those_within_2_percent_of_the_centre_depth():
    """util2d::getDepth's depthErrorRatio 0.02 is relative: at 3 m a neighbour 5 cm off (under
    6 cm) is averaged in, one 7 cm off is not."""
    depth = np.full((3, 3), 3.00, np.float32)
    depth[0, 1], depth[1, 0] = 3.05, 3.07
    expected = (4 * 3.00 + 2 * 3.05 + 2 * 2 * 3.00 + 4 * 3.00) / 14  # three edges and four corners
    assert smoothed_depth(depth, np.array([1]), np.array([1]))[0] == pytest.approx(expected, abs=1e-6)


def test_a_keypoint_without_depth_at_its_pixel_stays_without_depth_and_the_border_has_fewer_neighbours():
    depth = np.full((4, 4), 2.0, np.float32)
    depth[1, 1] = 0.0
    depth[0, 0] = 2.01
    smoothed = smoothed_depth(depth, np.array([1, 0]), np.array([1, 0]))
    assert smoothed[0] == 0.0
    assert smoothed[1] == pytest.approx((4 * 2.01 + 2 * 2.0 + 2 * 2.0) / 8, abs=1e-6)  # (0, 1), (1, 0); (1, 1) missing


def numpy_smoothed_depth(depth, rows, cols):
    """The smoothing written on the (N, 9) window with NumPy: the formula the compiled one keeps to the bit."""
    neighbour_rows, neighbour_cols = rows[:, None] + SMOOTHING_OFFSETS[:, 0], cols[:, None] + SMOOTHING_OFFSETS[:, 1]
    height, width = depth.shape
    inside = (neighbour_rows >= 0) & (neighbour_rows < height) & (neighbour_cols >= 0) & (neighbour_cols < width)
    window = depth[np.clip(neighbour_rows, 0, height - 1), np.clip(neighbour_cols, 0, width - 1)].astype(np.float64)
    centre = window[:, 4:5]
    with np.errstate(invalid="ignore"):
        near = np.abs(window - centre) < SMOOTHING_DEPTH_ERROR_RATIO * centre
    counted = inside & (window > 0) & np.isfinite(window) & near
    weights = SMOOTHING_WEIGHTS * counted
    mean = (weights * np.where(counted, window, 0.0)).sum(axis=1) / np.maximum(weights.sum(axis=1), 1e-12)
    return np.where(centre[:, 0] > 0, mean, 0.0)


def test_the_smoothing_gives_the_numpy_formulas_bits_with_missing_infinite_and_negative_depths_and_at_borders():
    rng = np.random.default_rng(5)
    for _ in range(200):
        height, width = rng.integers(1, 12, 2)
        depth = rng.uniform(0.5, 5.0, (height, width)) * rng.uniform(0.97, 1.03, (height, width))
        for value, share in ((0.0, 0.2), (np.nan, 0.05), (np.inf, 0.05), (-1.0, 0.05)):
            depth[rng.random((height, width)) < share] = value
        depth = depth.astype(np.float32)
        rows, cols = rng.integers(0, height, 40), rng.integers(0, width, 40)
        np.testing.assert_array_equal(
            smoothed_depth(depth, rows, cols), numpy_smoothed_depth(depth, rows, cols), strict=True
        )


def test_with_vis_depth_as_mask_corners_are_only_detected_where_the_depth_is_valid():
    rng = np.random.default_rng(4)
    gray = cv2.resize(rng.integers(0, 256, (30, 40), dtype=np.uint8), (320, 240), interpolation=cv2.INTER_NEAREST)
    depth = np.zeros((240, 320), np.float32)
    depth[:, 160:] = 1.5
    camera = Camera(fx=260.0, fy=260.0, cx=160.0, cy=120.0, width=320, height=240)
    masked = FeatureExtractor("GFTT_ORB", 300, camera, min_depth=1e-3, max_depth=np.inf, depth_mask=True)
    features = masked.extract(np.dstack([gray] * 3), depth)
    assert len(features) > 100 and features.has_depth.all()
    unmasked = FeatureExtractor("GFTT_ORB", 300, camera, min_depth=1e-3, max_depth=np.inf).extract(
        np.dstack([gray] * 3), depth
    )
    assert (~unmasked.has_depth).sum() > 50


def test_registration_variance_is_2_1981_times_the_quarter_point_of_the_distances_and_angles():
    """util3d::estimateMotion3DTo2D (Vis/PnPVarianceMedianRatio 4): 2.1981 x the squared distance,
    and 2.1981 x the angle seen from the camera, at index n/4 of the sorted ones; pairs
    without depth left out."""
    reference = np.tile([0.0, 0.0, 2.0], (9, 1))
    measured = reference + np.c_[[0.08, 0.01, 0.07, 0.02, 0.06, 0.03, 0.05, 0.04, np.nan], np.zeros((9, 2))]
    # eight valid pairs: index 2 of the sorted ones is the 3 cm offset, seen 2 m away
    variance = registration_variance(reference, measured)
    assert variance.translation == pytest.approx(2.1981 * 0.03**2)
    assert variance.rotation == pytest.approx(2.1981 * np.arctan(0.03 / 2.0))


@pytest.mark.parametrize(
    "assignment, message",
    [
        ("Odom/ResetCountdown=two", "parameter Odom/ResetCountdown expects an integer"),
        ("Kp/DetectorStrategy=7", "parameter Kp/DetectorStrategy must be one of 6, 8"),
    ],
)
def test_bad_rtabmap_parameters_are_one_line_cli_errors(assignment, message, tmp_path, capsys):
    from viewer_slam.cli import main

    code = main(
        ["record", str(tmp_path), "--pipeline", "rtabmap", "--param", assignment, "--out", str(tmp_path / "run.rrd")]
    )
    error = capsys.readouterr().err.strip()
    assert code == 2 and error.startswith("viewslam: error:") and message in error and "\n" not in error


def line_of_poses(count: int, step: float) -> dict[int, np.ndarray]:
    """Locations ``0 .. count - 1`` looking the same way, ``step`` apart along x."""
    return {i: make_pose(np.eye(3), [i * step, 0.0, 0.0]) for i in range(count)}


def test_proximity_paths_cut_a_chain_by_graph_depth_from_its_nearest_location():
    # Rtabmap::getPaths: from the nearest remaining candidate, its neighbours by odometry links
    # at margins 0 .. RGBD/ProximityMaxGraphDepth - 1 through candidates only, in id order.
    memory = chain_memory(121)
    poses = line_of_poses(121, 0.01)  # the camera at location 120, beyond 99
    assert proximity_paths(memory, poses, 120, set(range(100)), 50) == {99: list(range(50, 100)), 49: list(range(50))}
    # A location that is no candidate (here 70, say in STM) cuts the chain.
    candidates = set(range(100)) - {70}
    assert proximity_paths(memory, poses, 120, candidates, 50) == {
        99: list(range(71, 100)),
        69: list(range(20, 70)),
        19: list(range(20)),
    }


def test_a_path_proposes_its_location_nearest_the_camera_among_those_facing_it():
    """RTAB-Map 0.23.8 keys a path by the highest likelihood on it and its nearest location
    (``NearestPathKey``) and proposes that nearest location when it faces the camera, else the
    nearest of those that do: on 360_kidnap per frame its debug log shows, at location 87, the
    revisited start as a path of 27 locations all within RGBD/ProximityAngle, and the link goes
    to 27, its nearest, not to 1, the first of likelihood 1 (every location's adjusted
    likelihood is at least 1)."""
    memory = chain_memory(121, stm_size=10)  # 111 .. 120 in STM
    poses = line_of_poses(121, 0.004)  # 0.48 m in all, inside RGBD/ProximityPathFilteringRadius 1
    params = RtabmapParams()
    nearby = set(range(120))
    ones = dict.fromkeys(range(111), 1.0)
    # Equal likelihoods: the path whose nearest location has the higher id first.
    assert proximity_candidates(memory, poses, 120, nearby, ones, params) == [110, 60, 10]
    assert proximity_candidates(memory, poses, 120, nearby, {}, params) == [110, 60, 10]
    # A location standing out takes its path first; the path still proposes its nearest.
    assert proximity_candidates(memory, poses, 120, nearby, {**ones, 30: 3.0}, params) == [60, 110, 10]
    # A nearest location turned away (60 degrees, over RGBD/ProximityAngle 45) gives way to the
    # nearest of those facing the camera.
    poses[110] = poses[110] @ make_pose(Rotation.from_rotvec([0, np.radians(60), 0]).as_matrix(), [0, 0, 0])
    assert proximity_candidates(memory, poses, 120, nearby, ones, params) == [109, 60, 10]


class _RegistersEverything:
    """``register`` standing in for PnP: every pair registers 1 cm apart."""

    def __call__(self, old, new, camera, params, tree_seeds):
        return Registration(make_pose(np.eye(3), [0.01, 0.0, 0.0]), 100, 100)


def proximity_pipeline(poses: dict[int, np.ndarray]):
    """A pipeline whose memory chains the ``poses``' locations, the last ten in STM."""
    pipeline = PIPELINE(CAMERA, RtabmapParams())
    pipeline.memory = chain_memory(len(poses), stm_size=10)
    for i, pose in poses.items():
        pipeline.graph.add_location(i, 0, pose, Variance(1e-4, 1e-4))
        pipeline.edges.add_node(i, float(i))
    return pipeline


@pytest.mark.parametrize(("hypothesis_away", "suppressed"), [(0.08, True), (12.0, False)])
def test_a_proximity_link_near_the_hypothesis_takes_its_place(monkeypatch, hypothesis_away, suppressed):
    # Rtabmap::process: proximity detection runs before the hypothesis is registered; once a
    # proximity link is added, a hypothesis among the locations within RGBD/LocalRadius and
    # RGBD/ProximityMaxGraphDepth is not registered ("Proximity detection on N is close to
    # loop closure M, ignoring loop closure transform estimation"). The hypothesis, location
    # 20, is 39 links away (within 50); 12 m away it is beyond the 10 m radius, and is kept.
    monkeypatch.setattr(rtabmap_pipeline, "register", _RegistersEverything())
    poses = line_of_poses(60, 0.004)
    poses[20] = make_pose(np.eye(3), [poses[59][0, 3] - hypothesis_away, 0.0, 0.0])
    pipeline = proximity_pipeline(poses)
    frame = Frame(59, 59.0, np.zeros((1, 1, 3), np.uint8), np.zeros((1, 1), np.float32))
    events: list = []
    location, registered = pipeline.memory.locations[59], []
    left = pipeline._proximity(frame, location, {}, Hypothesis(20, 0.5), registered, Stopwatch(), events)
    pipeline._link(frame, location, registered, Stopwatch(), events)
    edges = [e for e in events if isinstance(e, GraphEdge)]
    assert any(e.accepted and e.detection == "proximity" for e in edges)
    assert (left is None) == suppressed
    assert any(not e.accepted and e.from_keyframe == 20 for e in edges) == suppressed


@pytest.mark.parametrize(("hypothesis", "accepted"), [(0, True), (2, False)])
def test_a_hypothesis_in_a_map_not_joined_yet_needs_only_the_aggressive_threshold(hypothesis, accepted):
    # Rtabmap::process (0.23.8, RGBD/AggressiveLoopThr 0.05): a hypothesis "not linked to
    # previous map of that hypothesis" (outside the current map's optimised graph) is verified
    # from 0.05; one in the current map still needs Rtabmap/LoopThr 0.11. Value 0.08 here.
    pipeline = PIPELINE(CAMERA, RtabmapParams())
    pipeline.memory = chain_memory(4)
    for i in range(4):
        pipeline.graph.add_location(i, i // 2, make_pose(np.eye(3), [0.1 * i, 0.0, 0.0]), Variance(1e-4, 1e-4))
        pipeline.edges.add_node(i, float(i))
    frame = Frame(3, 3.0, np.zeros((1, 1, 3), np.uint8), np.zeros((1, 1), np.float32))
    events: list = []
    location = pipeline.memory.locations[3]
    assert pipeline._accepts(frame, location, Hypothesis(hypothesis, 0.08), 5, events) == accepted
    assert not events  # a value under the threshold that applies is no rejected hypothesis
