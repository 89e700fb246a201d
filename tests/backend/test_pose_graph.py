import gtsam
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from viewer_slam.backend.pose_graph import LINEAR_SOLVERS, Edge, PoseGraph, information_from_sigmas, pose_matrices
from viewer_slam.geometry.se3 import invert, make_pose


def circle(n=12, radius=2.0):
    return [
        make_pose(
            Rotation.from_rotvec([0, -2 * np.pi * i / n, 0]).as_matrix(),
            [radius * np.sin(2 * np.pi * i / n), 0, radius * np.cos(2 * np.pi * i / n)],
        )
        for i in range(n)
    ]


def drifting_graph(truth, loop_information, linear_solver="cholesky"):
    """Odometry with a constant bias in every step, plus one exact loop edge."""
    bias = make_pose(Rotation.from_rotvec([0, 0.02, 0]).as_matrix(), [0.01, 0, 0])
    graph = PoseGraph(linear_solver=linear_solver)
    estimate = truth[0]
    graph.add_node(0, estimate)
    graph.add_prior(0, truth[0], information_from_sigmas(1e-4, 1e-4))
    odometry = information_from_sigmas(0.01, 0.01)
    for i in range(1, len(truth)):
        step = invert(truth[i - 1]) @ truth[i] @ bias
        estimate = estimate @ step
        graph.add_node(i, estimate)
        graph.add_edge(Edge(i - 1, i, step, odometry))
    loop = Edge(len(truth) - 1, 0, invert(truth[-1]) @ truth[0], loop_information, robust=True)
    graph.add_edge(loop)
    return graph, loop


def end_error(graph, truth):
    return np.linalg.norm(graph.poses[len(truth) - 1][:3, 3] - truth[-1][:3, 3])


@pytest.mark.parametrize("linear_solver", LINEAR_SOLVERS)
def test_loop_edge_pulls_the_drifted_end_back(linear_solver):
    truth = circle()
    graph, loop = drifting_graph(truth, information_from_sigmas(0.001, 0.001), linear_solver)
    drift = end_error(graph, truth)
    residual_before = graph.edge_residual(loop)[0]
    before, after = graph.optimize()
    assert after < 0.05 * before
    assert end_error(graph, truth) < 0.3 * drift
    assert graph.edge_residual(loop)[0] < 0.2 * residual_before


def test_removed_edge_no_longer_constrains():
    truth = circle()
    graph, loop = drifting_graph(truth, information_from_sigmas(0.001, 0.001))
    drift = end_error(graph, truth)
    graph.remove_edge(loop)
    before, after = graph.optimize()
    assert after < 1e-6 and before < 1e-6  # odometry alone is self-consistent
    assert np.isclose(end_error(graph, truth), drift)


def test_graph_without_constraints_is_left_alone():
    graph = PoseGraph()
    graph.add_node(0, np.eye(4))
    assert graph.optimize() == (0.0, 0.0)


def test_edge_chi2_is_the_squared_mahalanobis_error_of_the_residual():
    graph = PoseGraph()
    graph.add_node(0, np.eye(4))
    graph.add_node(1, make_pose(Rotation.from_rotvec([0, 0, 0.1]).as_matrix(), [0, 0, 0]))
    graph.add_node(2, make_pose(np.eye(3), [0.1, 0, 0]))
    information = np.diag([100.0] * 3 + [1000.0] * 3)
    # measured no motion: 0.1 rad about z -> 100 * 0.1^2 = 1; 0.1 m along x -> 1000 * 0.1^2 = 10
    assert graph.edge_chi2(Edge(0, 1, np.eye(4), information)) == pytest.approx(1.0)
    assert graph.edge_chi2(Edge(0, 2, np.eye(4), information)) == pytest.approx(10.0)


def test_edges_between_the_same_nodes_are_told_apart():
    graph = PoseGraph()
    graph.add_node(0, np.eye(4))
    graph.add_node(1, np.eye(4))
    first, second = Edge(0, 1, np.eye(4), np.eye(6)), Edge(0, 1, np.eye(4), np.eye(6))
    graph.add_edge(first)
    graph.add_edge(second)
    graph.remove_edge(second)
    assert graph.edges == [first] and graph.edges[0] is first


def test_a_graph_that_grew_and_lost_an_edge_optimises_as_one_built_without_it():
    # Factors are kept between optimisations: an edge taken back must leave no trace.
    truth = circle()
    grown, loop = drifting_graph(truth, information_from_sigmas(0.001, 0.001))
    grown.optimize()
    grown.remove_edge(loop)
    wrong = Edge(3, 9, make_pose(np.eye(3), [5.0, 0, 0]), information_from_sigmas(0.001, 0.001))
    grown.add_edge(wrong)
    grown.remove_edge(wrong)
    fresh, fresh_loop = drifting_graph(truth, information_from_sigmas(0.001, 0.001))
    fresh.remove_edge(fresh_loop)
    for node, pose in fresh.poses.items():
        grown.poses[node] = pose.copy()
    assert grown.optimize() == fresh.optimize()
    for node in fresh.poses:
        np.testing.assert_array_equal(grown.poses[node], fresh.poses[node])


@pytest.mark.parametrize("linear_solver", LINEAR_SOLVERS)
def test_translations_reach_the_weighted_least_squares_optimum(linear_solver):
    # Rotations measured and started at the identity stay there, so the problem is linear in x:
    # minimise w (x1 - 1)^2 + w (x2 - x1 - 1)^2 + v (x2 - 2.3)^2 with x0 held at 0 by the prior.
    w, v = 1e4, 4e4
    graph = PoseGraph(linear_solver=linear_solver)
    for node, x in enumerate([0.0, 0.9, 2.0]):
        graph.add_node(node, make_pose(np.eye(3), [x, 0, 0]))
    graph.add_prior(0, np.eye(4), information_from_sigmas(1e-6, 1e-6))
    for a, b, x, weight in [(0, 1, 1.0, w), (1, 2, 1.0, w), (0, 2, 2.3, v)]:
        graph.add_edge(Edge(a, b, make_pose(np.eye(3), [x, 0, 0]), np.diag([1e6] * 3 + [weight] * 3)))
    graph.optimize()
    normal_matrix = np.array([[2 * w, -w], [-w, w + v]])
    optimum = np.linalg.solve(normal_matrix, [w * 1.0 - w * 1.0, w * 1.0 + v * 2.3])
    np.testing.assert_allclose([graph.poses[1][0, 3], graph.poses[2][0, 3]], optimum, rtol=1e-6)
    np.testing.assert_allclose(graph.poses[2][:3, :3], np.eye(3), atol=1e-9)


def test_conjugate_gradients_agree_with_cholesky_where_loops_join_the_whole_history():
    rng = np.random.default_rng(0)
    truth = [np.eye(4)]
    for _ in range(119):
        truth.append(
            truth[-1] @ make_pose(Rotation.from_rotvec(rng.normal(0, 0.05, 3)).as_matrix(), rng.normal(0, 0.05, 3))
        )
    solved, errors = [], []
    for linear_solver in LINEAR_SOLVERS:
        graph = PoseGraph(huber_threshold=1.0, linear_solver=linear_solver)
        noise = np.random.default_rng(1)
        pairs = [(i - 1, i) for i in range(1, 120)] + [
            (int(j), i) for i in range(20, 120) for j in noise.choice(i - 5, 2)
        ]
        for a, b in pairs:
            error = make_pose(Rotation.from_rotvec(noise.normal(0, 0.01, 3)).as_matrix(), noise.normal(0, 0.01, 3))
            graph.add_edge(Edge(a, b, invert(truth[a]) @ truth[b] @ error, np.diag([1e4] * 3 + [1e4] * 3), robust=True))
        for node, pose in enumerate(truth):
            graph.add_node(
                node,
                pose @ make_pose(Rotation.from_rotvec(noise.normal(0, 0.02, 3)).as_matrix(), noise.normal(0, 0.05, 3)),
            )
        graph.add_prior(0, truth[0], information_from_sigmas(1e-6, 1e-6))
        errors.append(graph.optimize()[1])
        solved.append(np.stack([graph.poses[i] for i in range(120)]))
    # The steps are solved to g2o's tolerance, not exactly: the optima agree to a tenth of the
    # edges' 1 cm noise, their errors to 0.1 %.
    assert np.abs(solved[0][:, :3, 3] - solved[1][:, :3, 3]).max() < 1e-3
    assert errors[1] == pytest.approx(errors[0], rel=1e-3)


@pytest.mark.parametrize("linear_solver", LINEAR_SOLVERS)
def test_poses_changed_between_optimisations_count_as_in_a_graph_built_anew(linear_solver):
    # The values held from one optimisation to the next: a graph optimised, grown by a node,
    # one pose changed in place and one replaced, then optimised again,
    # ends to the bit where a graph given the same poses and edges at once ends.
    truth = circle()
    grown, _ = drifting_graph(truth, information_from_sigmas(0.01, 0.01), linear_solver)
    grown.optimize()
    grown.add_node(len(truth), truth[1])
    grown.add_edge(Edge(len(truth) - 1, len(truth), invert(truth[-1]) @ truth[1], information_from_sigmas(0.1, 0.1)))
    grown.poses[3][:3, 3] += 0.05
    grown.poses[5] = truth[5].copy()
    fresh = PoseGraph(linear_solver=linear_solver)
    for node_id, pose in grown.poses.items():
        fresh.add_node(node_id, pose.copy())
    for node_id, (pose, information) in grown.priors.items():
        fresh.add_prior(node_id, pose, information)
    for edge in grown.edges:
        fresh.add_edge(edge)
    assert grown.optimize() == fresh.optimize()
    for node_id, pose in fresh.poses.items():
        assert grown.poses[node_id].tobytes() == pose.tobytes()


def test_pose_matrices_read_in_one_call_are_atpose3_s_to_the_bit_in_the_order_asked():
    rng = np.random.default_rng(3)
    ids = [7, 2, 40, 0, 13]
    values = gtsam.Values()
    for node_id in ids:
        pose = np.eye(4)
        pose[:3, :3] = Rotation.random(random_state=node_id).as_matrix()
        pose[:3, 3] = rng.normal(scale=5.0, size=3)
        values.insert(node_id, gtsam.Pose3(pose))
    matrices = pose_matrices(values, ids)
    assert matrices.shape == (len(ids), 4, 4)
    for node_id, matrix in zip(ids, matrices):
        assert matrix.tobytes() == values.atPose3(node_id).matrix().tobytes()
