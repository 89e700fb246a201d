"""A Pose3 graph optimised with GTSAM's Levenberg-Marquardt.

Nodes and edges are kept in Python, each edge's GTSAM factor is made once, and the factor
graph grows as edges come: a graph of thousands of nodes (RGB-D SLAM v2 makes one per frame
and optimises after each) is not rebuilt from Python for every optimisation. Nor are the
initial values: the last optimisation's result is kept, and only the poses that differ from
it, to the bit, are set anew (a Pose3 holds a matrix's numbers exactly, so a pose read back
from the result and set again would be the same). Taking an edge
back (RTAB-Map rejects a loop closure whose optimised error is too large) or changing a
prior rebuilds it from the cached factors, priors first and edges in the order they came,
so the factors are always in the same order for the same graph.

Each Levenberg-Marquardt step solves its linear system either by sparse Cholesky
factorisation (GTSAM's multifrontal elimination) or by conjugate gradients with a
block-Jacobi preconditioner, g2o's ``LinearSolverPCG``. Cholesky is exact but fills in where
loop edges join distant nodes; on a graph that closes loops across its whole history its
factor approaches a dense 6N x 6N matrix, in memory and time. Conjugate gradients only
multiply by the sparse system.
"""

from dataclasses import dataclass

import gtsam
import numpy as np

from ..geometry.se3 import invert, rotation_angle


@dataclass(eq=False)
class Edge:
    """``relative = T_from^-1 T_to`` measured with ``information`` (6x6, rotation first).
    Edges are compared by identity: two measurements between the same nodes are distinct."""

    from_id: int
    to_id: int
    relative: np.ndarray
    information: np.ndarray
    robust: bool = False


CHOLESKY = "cholesky"
PCG = "pcg"
LINEAR_SOLVERS = (CHOLESKY, PCG)
# g2o's LinearSolverPCG stops once r^T M^-1 r (M the block-diagonal preconditioner) falls to
# 1e-6 of its first value, after at most as many iterations as the system has rows. GTSAM
# stops at epsilon_rel^2 times the first value.
PCG_RELATIVE_TOLERANCE = 1e-6


def information_from_sigmas(rotation_sigma: float, translation_sigma: float) -> np.ndarray:
    """Diagonal information in GTSAM's tangent order (rotation, then translation)."""
    return np.diag([rotation_sigma**-2] * 3 + [translation_sigma**-2] * 3)


def pose_matrices(values: gtsam.Values, ids: list[int]) -> np.ndarray:
    """The ``(N, 4, 4)`` matrices of the poses ``ids`` in ``values``, read in one call rather
    than one ``atPose3`` each: GTSAM gives every pose's rotation (row by row) and translation
    as a row, in key order, the same doubles ``Pose3.matrix`` holds."""
    rows = gtsam.utilities.extractPose3(values)
    position = {key: row for row, key in enumerate(values.keys())}
    rows = rows[[position[node_id] for node_id in ids]]
    matrices = np.zeros((len(ids), 4, 4))
    matrices[:, :3, :3] = rows[:, :9].reshape(-1, 3, 3)
    matrices[:, :3, 3] = rows[:, 9:]
    matrices[:, 3, 3] = 1.0
    return matrices


class PoseGraph:
    """Nodes with initial guesses, between-edges and priors; optimised on demand."""

    def __init__(self, huber_threshold: float = 1.345, linear_solver: str = CHOLESKY):
        if linear_solver not in LINEAR_SOLVERS:
            raise ValueError(f"linear solver {linear_solver!r}: expected one of {', '.join(LINEAR_SOLVERS)}")
        self.linear_solver = linear_solver
        self.poses: dict[int, np.ndarray] = {}
        self.edges: list[Edge] = []
        self.priors: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self.huber_threshold = huber_threshold
        self._factors: dict[Edge, gtsam.NonlinearFactor] = {}
        self._graph: gtsam.NonlinearFactorGraph | None = None
        # The GTSAM values of the last build or optimisation, their nodes and their poses.
        self._values = gtsam.Values()
        self._value_ids: list[int] = []
        self._value_poses = np.zeros((0, 4, 4))

    def add_node(self, node_id: int, pose: np.ndarray) -> None:
        self.poses[node_id] = np.array(pose, dtype=np.float64)

    def add_prior(self, node_id: int, pose: np.ndarray, information: np.ndarray) -> None:
        self.priors[node_id] = (np.array(pose, dtype=np.float64), information)
        self._graph = None

    def remove_prior(self, node_id: int) -> None:
        if self.priors.pop(node_id, None) is not None:
            self._graph = None

    def add_edge(self, edge: Edge) -> None:
        self.edges.append(edge)
        factor = self._factors[edge] = gtsam.BetweenFactorPose3(
            edge.from_id, edge.to_id, gtsam.Pose3(edge.relative), self._noise(edge.information, edge.robust)
        )
        if self._graph is not None:
            self._graph.add(factor)

    def remove_edge(self, edge: Edge) -> None:
        self.edges.remove(edge)
        del self._factors[edge]
        self._graph = None

    def _noise(self, information: np.ndarray, robust: bool):
        model = gtsam.noiseModel.Gaussian.Information(information)
        if robust:
            return gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Huber.Create(self.huber_threshold), model)
        return model

    def _build(self) -> tuple[gtsam.NonlinearFactorGraph, gtsam.Values]:
        if self._graph is None:
            self._graph = gtsam.NonlinearFactorGraph()
            for node_id, (pose, information) in self.priors.items():
                self._graph.add(gtsam.PriorFactorPose3(node_id, gtsam.Pose3(pose), self._noise(information, False)))
            for edge in self.edges:
                self._graph.add(self._factors[edge])
        return self._graph, self._values_of_poses()

    def _values_of_poses(self) -> gtsam.Values:
        """``poses`` as GTSAM values, made anew only where they differ from the values held."""
        ids = list(self.poses)
        poses = np.stack([self.poses[node_id] for node_id in ids]) if ids else np.zeros((0, 4, 4))
        held = len(self._value_ids)
        if ids[:held] != self._value_ids:
            self._values, held = gtsam.Values(), 0
        bits = poses[:held].view(np.uint64).reshape(held, 16)
        for changed in np.flatnonzero((bits != self._value_poses.view(np.uint64).reshape(held, 16)).any(axis=1)):
            self._values.update(ids[changed], gtsam.Pose3(poses[changed]))
        for added in range(held, len(ids)):
            self._values.insert(ids[added], gtsam.Pose3(poses[added]))
        self._value_ids, self._value_poses = ids, poses
        return self._values

    def error(self) -> float:
        graph, values = self._build()
        return graph.error(values)

    def optimize(self, max_iterations: int = 100, relative_tolerance: float | None = None) -> tuple[float, float]:
        """Optimise all nodes in place; returns the graph error before and after.

        With ``relative_tolerance`` the optimiser stops once an iteration lowers the error by
        less than that fraction (RGB-D SLAM v2's ``optimizer_iterations`` below 1).
        """
        graph, values = self._build()
        if not self.edges and not self.priors:
            before = graph.error(values)
            return before, before
        parameters = gtsam.LevenbergMarquardtParams()
        parameters.setMaxIterations(max_iterations)
        if relative_tolerance is not None:
            parameters.setRelativeErrorTol(relative_tolerance)
        if self.linear_solver == PCG:
            parameters.setIterativeParams(self._pcg_parameters())
            parameters.setLinearSolverType("ITERATIVE")
        optimizer = gtsam.LevenbergMarquardtOptimizer(graph, values, parameters)
        before = optimizer.error()  # the optimiser's own graph.error of the values, before and after
        result = optimizer.optimize()
        optimised = pose_matrices(result, self._value_ids)
        self.poses.update(zip(self._value_ids, optimised))
        self._values = gtsam.Values(result)
        self._value_poses = optimised.copy()
        return before, optimizer.error()

    def _pcg_parameters(self) -> gtsam.PCGSolverParameters:
        """g2o's stopping rule; single-threaded, as g2o's solver is, so sums keep their order."""
        pcg = gtsam.PCGSolverParameters()
        pcg.preconditioner = gtsam.BlockJacobiPreconditionerParameters()
        pcg.epsilon_rel = PCG_RELATIVE_TOLERANCE**0.5
        pcg.epsilon_abs = 0.0
        pcg.maxIterations = 6 * len(self.poses)
        pcg.parallel = False
        return pcg

    def edge_chi2(self, edge: Edge) -> float:
        """Squared Mahalanobis distance ``r^T information r`` of the edge's residual
        ``r = Log(relative^-1 T_from^-1 T_to)`` at the current poses, robust kernel ignored."""
        predicted = gtsam.Pose3(invert(self.poses[edge.from_id]) @ self.poses[edge.to_id])
        residual = gtsam.Pose3(edge.relative).localCoordinates(predicted)
        return float(residual @ edge.information @ residual)

    def edge_residual(self, edge: Edge) -> tuple[float, float]:
        """Translation (m) and rotation (rad) by which the current poses disagree with an edge."""
        predicted = invert(self.poses[edge.from_id]) @ self.poses[edge.to_id]
        residual = invert(edge.relative) @ predicted
        return float(np.linalg.norm(residual[:3, 3])), float(rotation_angle(residual[:3, :3]))
