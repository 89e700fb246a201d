"""Environment measurement model (Endres et al., T-RO 2014): check an edge against the depth.

Points seen by one node are projected into the other. Where they land in front of the
surface the other node measured, that node looked through empty space at them: the
transformation contradicts the depth. Points behind the surface are merely occluded and
say nothing. A transformation is plausible when enough of the comparable points agree.
"""

import numpy as np

from ...geometry.camera import Camera
from ...geometry.se3 import invert, transform_points
from .node import MAP_STEP, Node


def _consistency(observer: Node, points: np.ndarray, camera: Camera, tolerance: float) -> tuple[int, int]:
    """(consistent, contradicting) counts of ``points`` (in ``observer``'s camera frame)."""
    points = points[points[:, 2] > 0]
    pixels = np.rint(camera.project(points) / MAP_STEP).astype(int)
    rows, cols = pixels[:, 1], pixels[:, 0]
    inside = (rows >= 0) & (rows < observer.depth.shape[0]) & (cols >= 0) & (cols < observer.depth.shape[1])
    measured = observer.depth[rows[inside], cols[inside]].astype(np.float64)
    predicted = points[inside, 2]
    comparable = measured > 0
    measured, predicted = measured[comparable], predicted[comparable]
    margin = tolerance * measured
    consistent = int(np.count_nonzero(np.abs(predicted - measured) <= margin))
    contradicting = int(np.count_nonzero(predicted < measured - margin))
    return consistent, contradicting


def observability(node: Node, other: Node, node_from_other: np.ndarray, camera: Camera, tolerance: float) -> float:
    """Share of comparable points, projected both ways, whose depth agrees; 0 without overlap."""
    points_other, _ = other.cloud(camera)
    points_node, _ = node.cloud(camera)
    forward = _consistency(node, transform_points(node_from_other, points_other), camera, tolerance)
    backward = _consistency(other, transform_points(invert(node_from_other), points_node), camera, tolerance)
    consistent = forward[0] + backward[0]
    comparable = consistent + forward[1] + backward[1]
    return consistent / comparable if comparable else 0.0
