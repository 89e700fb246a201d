"""Unit tests of the rgbdslam building blocks: candidates, segments, EMM, parameters."""

import numpy as np
import pytest
from binary_descriptors import descriptors
from scipy.spatial.transform import Rotation

from viewer_slam.backend.pose_graph import CHOLESKY, PCG, PoseGraph, information_from_sigmas
from viewer_slam.errors import InputError
from viewer_slam.frontend.features import Features
from viewer_slam.geometry.camera import Camera
from viewer_slam.geometry.se3 import invert, make_pose
from viewer_slam.pipelines.base import pipeline_class
from viewer_slam.pipelines.events import GraphOptimized
from viewer_slam.pipelines.params import apply_overrides
from viewer_slam.pipelines.rgbdslam import RgbdSlam, RgbdSlamParams
from viewer_slam.pipelines.rgbdslam.candidates import (
    NEIGHBOUR,
    PREDECESSOR,
    SAMPLED,
    edge_targets,
    graph_neighbourhood,
    neighbour_weights,
    weighted_sample,
)
from viewer_slam.pipelines.rgbdslam.emm import observability
from viewer_slam.pipelines.rgbdslam.graph import NodeGraph
from viewer_slam.pipelines.rgbdslam.motion import MeasuredFeatures, edge_information, match
from viewer_slam.pipelines.rgbdslam.node import MAP_STEP, Node
from viewer_slam.pipelines.rgbdslam.pipeline import no_motion_information
from viewer_slam.pipelines.rgbdslam.segments import Segments

CAMERA = Camera(262.5, 262.5, 159.5, 119.5, 320, 240)
EMPTY = Features(
    np.zeros((0, 2), np.float32), np.zeros((0, 32), np.uint8), np.zeros(0, np.float32), np.zeros((0, 3)), True
)


def chain_graph(count):
    adjacency = {i: set() for i in range(count)}
    for i in range(count - 1):
        adjacency[i].add(i + 1)
        adjacency[i + 1].add(i)
    return adjacency


def test_registered_under_its_name_with_v2_defaults():
    assert pipeline_class("rgbdslam") is RgbdSlam
    defaults = RgbdSlamParams().model_dump(by_alias=True)
    # parameter_server.cpp's defaults
    assert defaults["feature_detector_type"] == "ORB"
    assert (
        defaults["max_keypoints"],
        defaults["max_matches"],
        defaults["ransac_iterations"],
        defaults["min_matches"],
    ) == (600, 300, 200, 20)
    assert (
        defaults["predecessor_candidates"],
        defaults["neighbor_candidates"],
        defaults["min_sampled_candidates"],
        defaults["geodesic_depth"],
    ) == (4, 4, 4, 3)
    assert (defaults["min_translation_meter"], defaults["min_rotation_degree"]) == (0.0, 0.0)
    assert (defaults["nn_distance_ratio"], defaults["sigma_depth"], defaults["adjuster_max_iterations"]) == (
        0.95,
        0.01,
        5,
    )
    assert defaults["matcher_type"] == "FLANN"
    assert defaults["keep_all_nodes"] is False and defaults["observability_threshold"] <= 0
    assert (defaults["optimizer_iterations"], defaults["optimizer_skip_step"], defaults["backend_solver"]) == (
        0.01,
        1,
        "pcg",
    )
    assert all(defaults[k] == 0 for k in defaults if k.startswith("viewslam_"))  # ours: off


def test_backend_solver_picks_conjugate_gradients_or_sparse_cholesky_as_v2s_g2o_solvers():
    assert NodeGraph("pcg").poses.linear_solver == PCG
    assert NodeGraph("cholmod").poses.linear_solver == NodeGraph("csparse").poses.linear_solver == CHOLESKY
    with pytest.raises(InputError, match="backend_solver"):
        apply_overrides(RgbdSlamParams(), {"backend_solver": "dense"}, "--param")


def test_surf_is_refused_with_the_reason():
    with pytest.raises(InputError, match="SURF is patented"):
        apply_overrides(RgbdSlamParams(), {"feature_detector_type": "SURF"}, "--param")


def test_graph_neighbourhood_is_bounded_by_the_geodesic_depth():
    adjacency = chain_graph(10)
    adjacency[9].add(0)
    adjacency[0].add(9)  # a loop closure
    assert graph_neighbourhood(adjacency, 9, 2) == [0, 1, 7, 8]


def test_neighbours_are_weighted_by_their_id_distance_and_skip_the_sequential_ones():
    # predecessor 20 with 3 sequential targets: 17..19 are sequential, the rest weigh |20 - id|
    assert neighbour_weights([5, 10, 17, 18, 19, 21], 20, 3) == {5: 15, 10: 10, 21: 1}
    rng = np.random.default_rng(0)
    draws = [weighted_sample({5: 15, 10: 10, 21: 1}, 1, rng)[0] for _ in range(20000)]
    frequencies = np.array([draws.count(n) for n in (5, 10, 21)]) / len(draws)
    np.testing.assert_allclose(frequencies, np.array([15, 10, 1]) / 26, atol=0.01)
    assert sorted(weighted_sample({5: 15, 10: 10, 21: 1}, 5, rng)) == [5, 10, 21]  # without replacement


def test_a_small_graph_is_compared_whole():
    targets = edge_targets(list(range(8)), chain_graph(8), [0], 7, True, 3, 4, 4, 3, np.random.default_rng(0))
    assert sorted(targets) == [(n, PREDECESSOR) for n in range(8)]


def test_candidates_are_predecessors_weighted_neighbours_and_sampled_keyframes():
    adjacency = chain_graph(30)
    adjacency[29] |= {5, 12}
    adjacency[5].add(29)
    adjacency[12].add(29)
    keyframes = [0, 8, 16, 24]

    def draw(seed):
        return edge_targets(list(range(30)), adjacency, keyframes, 29, True, 3, 4, 4, 3, np.random.default_rng(seed))

    targets = draw(0)
    kinds = {kind: [n for n, k in targets if k == kind] for kind in (PREDECESSOR, NEIGHBOUR, SAMPLED)}
    assert kinds[PREDECESSOR] == [29, 28, 27, 26]
    # within 3 edges of 29 but not sequential: 4..7 and 11..14 through the two loop edges
    assert set(kinds[NEIGHBOUR]) <= {3, 4, 5, 6, 7, 10, 11, 12, 13, 14} and len(kinds[NEIGHBOUR]) == 4
    assert set(kinds[SAMPLED]) <= set(keyframes) and not set(kinds[SAMPLED]) & set(kinds[NEIGHBOUR])
    assert draw(0) == targets and any(draw(seed) != targets for seed in range(1, 5))


def test_edge_information_is_inliers_over_squared_rms_error():
    # v2: I * inliers / rmse^2 on (translation, quaternion vector); the quaternion part is half the angle
    np.testing.assert_allclose(edge_information(50, 0.5), np.diag([50.0] * 3 + [200.0] * 3))
    np.testing.assert_allclose(no_motion_information(0.05), np.diag([5.0] * 3 + [20.0] * 3))  # I / dt


def chain_of_nodes(graph: NodeGraph, count: int) -> None:
    """``count`` featureless nodes 0.1 m apart along x, in one segment, without edges."""
    graph.segments.add(0)
    for node_id in range(count):
        node = Node.from_frame(
            node_id,
            node_id,
            float(node_id),
            MeasuredFeatures(EMPTY),
            np.zeros((8, 8, 3), np.uint8),
            np.zeros((8, 8), np.float32),
            0,
        )
        graph.add(node, make_pose(np.eye(3), [0.1 * node_id, 0, 0]), np.eye(4))


def test_edges_with_large_errors_are_pruned_as_v2_does():
    graph = NodeGraph("pcg")
    chain_of_nodes(graph, 3)
    information = np.diag([1e6] * 3 + [1000.0] * 3)
    step = make_pose(np.eye(3), [0.1, 0, 0])
    graph.connect(0, 1, step, information)  # exact: chi2 0
    graph.connect(1, 2, make_pose(np.eye(3), [0.2, 0, 0]), information)  # 0.1 m off: chi2 10 > 5
    graph.connect(0, 2, make_pose(np.eye(3), [0.25, 0, 0]), information)  # 0.05 m off: chi2 2.5
    graph.connect(0, 2, make_pose(np.eye(3), [0.3, 0, 0]), information)  # 0.1 m off, not consecutive
    assert graph.prune_edges_with_error_above(5.0) == 2
    kept = {(e.from_id, e.to_id, round(float(e.relative[0, 3]), 3)) for e in graph.poses.edges}
    assert kept == {(0, 1, 0.1), (0, 2, 0.25), (1, 2, 0.0)}  # the consecutive one became no motion
    no_motion = next(e for e in graph.poses.edges if (e.from_id, e.to_id) == (1, 2))
    # v2 sets its information to I on g2o's (translation, quaternion vector ≈ half the angle)
    np.testing.assert_allclose(no_motion.information, np.diag([0.25] * 3 + [1.0] * 3))


def test_the_final_optimisation_prunes_above_5_then_1_then_a_quarter_as_v2s_batch_run():
    slam = RgbdSlam(CAMERA)
    chain_of_nodes(slam.graph, 3)
    step = make_pose(np.eye(3), [0.1, 0, 0])
    strong = np.diag([1e8] * 3 + [1e6] * 3)
    slam.graph.poses.add_prior(0, np.eye(4), information_from_sigmas(1e-6, 1e-6))
    slam.graph.connect(0, 1, step, strong)
    slam.graph.connect(1, 2, step, strong)
    # the consecutive edges hold the nodes where they are; each edge 0 -> 2 is off by d along
    # x, squared Mahalanobis error 1000 d^2: 10, 2.5, 0.625 and 0.1
    for offset in (0.1, 0.05, 0.025, 0.01):
        slam.graph.connect(0, 2, make_pose(np.eye(3), [0.2 + offset, 0, 0]), np.diag([1e6] * 3 + [1000.0] * 3))
    events = slam.finish()
    # one final optimisation, then one after each of the three rounds, each of which pruned one edge
    assert sum(isinstance(event, GraphOptimized) for event in events) == 4
    kept = sorted(round(float(e.relative[0, 3]), 3) for e in slam.graph.poses.edges if e.from_id == 0 and e.to_id == 2)
    assert kept == [0.21]


def test_joining_segments_moves_the_newer_one_onto_the_older():
    graph = PoseGraph()
    old = make_pose(Rotation.from_rotvec([0.0, 0.3, 0.0]).as_matrix(), [1.0, 0.0, 0.0])
    graph.add_node(0, np.eye(4))
    graph.add_node(1, old)
    guess = make_pose(np.eye(3), [5.0, 5.0, 0.0])
    graph.add_node(2, guess)
    graph.add_node(3, guess @ make_pose(np.eye(3), [0.1, 0.0, 0.0]))
    graph.add_prior(0, np.eye(4), information_from_sigmas(1e-6, 1e-6))
    graph.add_prior(2, guess, information_from_sigmas(1.0, 1.0))
    segments = Segments()
    segments.add(0)
    segments.add(2)
    node_segment = {0: 0, 1: 0, 2: 2, 3: 2}
    relative = make_pose(Rotation.from_rotvec([0.1, 0.0, 0.0]).as_matrix(), [0.0, 0.2, 0.0])  # node 1 sees node 3 here
    assert segments.join(graph, node_segment, 1, 3, relative)
    np.testing.assert_allclose(invert(graph.poses[1]) @ graph.poses[3], relative, atol=1e-12)
    np.testing.assert_allclose(
        invert(graph.poses[2]) @ graph.poses[3], make_pose(np.eye(3), [0.1, 0.0, 0.0]), atol=1e-12
    )  # rigidly moved
    np.testing.assert_array_equal(graph.poses[1], old)  # the older segment stays
    assert 2 not in graph.priors and 0 in graph.priors
    assert segments.root(2) == 0
    assert not segments.join(graph, node_segment, 0, 3, relative)


def wall_node(node_id, distance):
    """A node facing a flat wall ``distance`` metres away."""
    depth = np.full((CAMERA.height, CAMERA.width), distance, np.float32)
    rgb = np.zeros((CAMERA.height, CAMERA.width, 3), np.uint8)
    return Node.from_frame(node_id, node_id, 0.0, MeasuredFeatures(EMPTY), rgb, depth, 0)


def test_environment_model_accepts_the_true_motion_and_rejects_a_contradiction():
    near, far = wall_node(0, 1.5), wall_node(1, 2.0)
    truth = make_pose(np.eye(3), [0.0, 0.0, 0.5])  # the far node stands 0.5 m behind the near one
    assert near.depth.shape == (CAMERA.height // MAP_STEP, CAMERA.width // MAP_STEP)
    assert observability(near, far, invert(truth), CAMERA, 0.05) == pytest.approx(1.0)
    # Claiming both stood at the same place puts the near wall in front of the far wall's
    # measured surface: the far view looked through empty space there.
    assert observability(near, far, np.eye(4), CAMERA, 0.05) < 0.1


def measured(points=None, descriptor_rows=None):
    """Features with these 3D points (default: all at (1, 1, 1)) and 32-byte descriptors
    (default: all zero), every one with depth."""
    count = len(points if points is not None else descriptor_rows)
    points = np.ones((count, 3)) if points is None else points
    descriptor_rows = np.zeros((count, 32), np.uint8) if descriptor_rows is None else descriptor_rows
    return MeasuredFeatures.from_features(
        Features(np.zeros((count, 2), np.float32), descriptor_rows, np.ones(count, np.float32), points, True)
    )


def test_v2s_default_orb_matching_takes_each_nearest_neighbour_within_half_the_bits_nearest_first():
    # node keypoints at 0, 100 and 250 bits; frame keypoints at 90 (nearest: 100, 10 bits),
    # 30 (0, 30 bits), 5 (0, 5 bits), 170 (100, 70 bits) and 127 (100, 27 bits). No ratio
    # test, a node keypoint matched by several, ordered by distance: 5, 10, 27, 30, 70.
    frame = measured(descriptor_rows=descriptors(90, 30, 5, 170, 127))
    node = measured(descriptor_rows=descriptors(0, 100, 250))
    frame_index, node_index = match(frame, node, RgbdSlamParams(), np.random.default_rng(0))
    assert frame_index.tolist() == [2, 0, 4, 1, 3] and node_index.tolist() == [0, 1, 1, 0, 1]
    # half of the 256 bits or more apart is no match: 227 bits is 127 from 100, 228 is 128
    pair, defaults = measured(descriptor_rows=descriptors(0, 100)), RgbdSlamParams()
    assert match(measured(descriptor_rows=descriptors(227)), pair, defaults, np.random.default_rng(0))[1].tolist() == [
        1
    ]
    assert match(measured(descriptor_rows=descriptors(228)), pair, defaults, np.random.default_rng(0))[0].size == 0
    capped = apply_overrides(RgbdSlamParams(), {"max_matches": 4, "min_matches": 3}, "--param")
    assert match(frame, node, capped, np.random.default_rng(0))[0].tolist() == [2, 0, 4, 1]


def test_equal_distances_sort_in_random_order_and_the_ratio_test_on_request():
    # six frame keypoints all 3 bits from node keypoint 0: every order is as likely
    frame, node = measured(descriptor_rows=descriptors(*[3] * 6)), measured(descriptor_rows=descriptors(0, 200))
    firsts = {int(match(frame, node, RgbdSlamParams(), np.random.default_rng(seed))[0][0]) for seed in range(40)}
    assert firsts == set(range(6))
    # BRUTEFORCE_OPENCV: the ratio test (3 against 197 bits passes), node keypoint 0 matched once
    ratio = apply_overrides(RgbdSlamParams(), {"matcher_type": "BRUTEFORCE_OPENCV"}, "--param")
    frame_index, node_index = match(frame, node, ratio, np.random.default_rng(0))
    assert frame_index.tolist() == [0] and node_index.tolist() == [0]


def test_a_transformation_backed_by_too_small_a_share_of_the_matches_is_refused_when_asked():
    from viewer_slam.pipelines.rgbdslam.motion import estimate_motion

    rng = np.random.default_rng(3)
    node_points = rng.uniform([-1, -1, 1], [1, 1, 3], (100, 3))
    frame_from_node = make_pose(
        Rotation.from_rotvec(np.array([0.02, -0.03, 0.01])).as_matrix(), np.array([0.05, 0.0, -0.02])
    )
    frame_points = node_points @ frame_from_node[:3, :3].T + frame_from_node[:3, 3]
    frame_points[25:] = rng.uniform([-1, -1, 1], [1, 1, 3], (75, 3))  # 25 true matches among 100
    matches = (np.arange(100), np.arange(100))
    frame, node = measured(frame_points), measured(node_points)
    motion, _ = estimate_motion(frame, node, matches, RgbdSlamParams(), np.random.default_rng(0))
    assert motion is not None and motion.inlier_count == 25
    assert np.allclose(motion.transform, invert(frame_from_node), atol=1e-6)
    refused, reason = estimate_motion(
        frame, node, matches, RgbdSlamParams(), np.random.default_rng(0), min_inlier_ratio=0.3
    )  # viewslam_min_inlier_ratio, ours
    assert refused is None and reason == "too few of the matches are inliers (25 of 100, < 0.3)"


def test_a_match_faster_than_v2s_bounds_per_second_is_refused():
    from viewer_slam.pipelines.rgbdslam.motion import smooth_enough

    defaults = RgbdSlamParams()
    assert (defaults.max_translation_meter, defaults.max_rotation_degree) == (1e10, 360.0)  # parameter_server.cpp

    def turned(degrees, metres=0.0):
        return make_pose(
            Rotation.from_rotvec(np.radians(degrees) * np.array([0.6, 0.0, 0.8])).as_matrix(),
            np.array([metres, 0.0, 0.0]),
        )

    frame_gap = 1 / 30
    # isSmallTrafo: angle / seconds < max_rotation_degree, dist / seconds < max_translation_meter
    assert smooth_enough(turned(11.5), frame_gap, defaults)  # 345 deg/s
    assert not smooth_enough(turned(12.5), frame_gap, defaults)  # 375 deg/s
    assert smooth_enough(turned(60.0), 1.0, defaults)  # a loop closure a second back
    assert smooth_enough(turned(170.0), 0.0, defaults)  # no time between: not tested
    slow = apply_overrides(RgbdSlamParams(), {"max_translation_meter": "1"}, "--param", text=True)
    assert smooth_enough(turned(0.0, 0.03), frame_gap, slow)  # 0.9 m/s
    assert not smooth_enough(turned(0.0, 0.04), frame_gap, slow)  # 1.2 m/s
