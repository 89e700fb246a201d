"""Solve the bundles of kidnap_bundles.npz with g2o itself, as RTAB-Map's OptimizerG2O::optimizeBA
sets them up (types_sba: VertexCam, EdgeProjectP2SC / EdgeProjectP2MC under a Huber kernel,
EdgeSBACam for the link; Levenberg-Marquardt; two passes, edges over the kernel's delta dropped
and their points reset after the first), and print each adjusted pose.

Not part of the suite: it needs g2o's Python bindings (``pip install g2o-python==0.0.12
"numpy<2"`` in a venv of its own; those bindings crash on NumPy 2 matrices).
"""

import sys

import g2o
import numpy as np


def camera(pose: np.ndarray, K: np.ndarray, baseline: float) -> g2o.SBACam:
    cam = g2o.SBACam(g2o.SE3Quat(np.ascontiguousarray(pose[:3, :3]), np.ascontiguousarray(pose[:3, 3])))
    cam.set_cam(K[0, 0], K[1, 1], K[0, 2], K[1, 2], baseline)
    return cam


def solve(bundle: dict) -> np.ndarray:
    K = bundle["K"]
    pixel_variance, delta, baseline, iterations = bundle["s"]
    optimizer = g2o.SparseOptimizer()
    optimizer.set_algorithm(g2o.OptimizationAlgorithmLevenberg(g2o.BlockSolverSE3(g2o.LinearSolverEigenSE3())))
    vertex_of = {}
    for index, (frame, pose) in enumerate(zip(bundle["hid"], bundle["hpose"])):
        vertex = g2o.VertexCam()
        vertex.set_id(index)
        vertex.set_estimate(camera(pose, K, baseline))
        vertex.set_fixed(True)
        optimizer.add_vertex(vertex)
        vertex_of[int(frame)] = vertex
    free = g2o.VertexCam()
    free.set_id(len(vertex_of))
    free.set_estimate(camera(bundle["pose"], K, baseline))
    optimizer.add_vertex(free)
    vertex_of[-1] = free
    link_frame, translation_variance, rotation_variance = bundle["link"]
    link = g2o.EdgeSBACam()
    link.set_vertex(0, vertex_of[int(link_frame)])
    link.set_vertex(1, free)
    relative = bundle["lrel"]
    link.set_measurement(g2o.SE3Quat(np.ascontiguousarray(relative[:3, :3]), np.ascontiguousarray(relative[:3, 3])))
    link.set_information(np.diag([1 / translation_variance] * 3 + [1 / rotation_variance] * 3))
    optimizer.add_edge(link)
    first_point = 100000
    for index, point in enumerate(bundle["points"]):
        vertex = g2o.VertexPointXYZ()
        vertex.set_id(first_point + index)
        vertex.set_estimate(np.asarray(point, float))
        vertex.set_marginalized(True)
        optimizer.add_vertex(vertex)
    edges = []
    for point, frame, (u, v), depth in zip(bundle["opoint"], bundle["oframe"], bundle["opix"], bundle["odepth"]):
        if np.isfinite(depth) and depth > 0:
            edge = g2o.EdgeProjectP2SC()
            edge.set_measurement(np.array([u, v, u - baseline * K[0, 0] / depth]))
            edge.set_information(np.eye(3) / pixel_variance)
        else:
            edge = g2o.EdgeProjectP2MC()
            edge.set_measurement(np.array([u, v]))
            edge.set_information(np.eye(2) / pixel_variance)
        edge.set_vertex(0, optimizer.vertex(first_point + int(point)))
        edge.set_vertex(1, vertex_of[int(frame)])
        kernel = g2o.RobustKernelHuber()
        kernel.set_delta(delta)
        edge.set_robust_kernel(kernel)
        optimizer.add_edge(edge)
        edges.append((edge, int(point)))
    optimizer.initialize_optimization()
    for iteration_count in (5, int(iterations)):
        optimizer.optimize(iteration_count)
        for edge, point in edges:
            if edge.level() == 0 and edge.chi2() > delta:
                edge.set_level(1)
                optimizer.vertex(first_point + point).set_estimate(np.asarray(bundle["points"][point], float))
        optimizer.initialize_optimization(0)
    estimate = free.estimate()
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = estimate.rotation().matrix(), estimate.translation()
    return pose


if __name__ == "__main__":
    stored = np.load(sys.argv[1] if len(sys.argv) > 1 else "kidnap_bundles.npz")
    for k in range(int(stored["count"])):
        bundle = {key.split("_", 1)[1]: stored[key] for key in stored.files if key.startswith(f"{k}_")}
        print(k, np.array2string(solve(bundle), precision=9, separator=", "))
