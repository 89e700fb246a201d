import numpy as np
import pytest

from viewer_slam.backend.pose_graph import Edge, PoseGraph, information_from_sigmas
from viewer_slam.geometry.se3 import exp_so3, invert, make_pose


def circle(n=12, radius=2.0):
    return [make_pose(exp_so3([0, -2 * np.pi * i / n, 0]), [radius * np.sin(2 * np.pi * i / n), 0, radius * np.cos(2 * np.pi * i / n)])
            for i in range(n)]


def drifting_graph(truth, loop_information):
    """Odometry with a constant bias in every step, plus one exact loop edge."""
    bias = make_pose(exp_so3([0, 0.02, 0]), [0.01, 0, 0])
    graph = PoseGraph()
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


def test_loop_edge_pulls_the_drifted_end_back():
    truth = circle()
    graph, loop = drifting_graph(truth, information_from_sigmas(0.001, 0.001))
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
    graph.add_node(1, make_pose(exp_so3([0, 0, 0.1]), [0, 0, 0]))
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
