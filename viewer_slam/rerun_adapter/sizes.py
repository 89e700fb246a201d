"""How large to draw things, from the size of the scene.

A frustum or a point of fixed size is a tangle on a desk seen from 12 cm of motion and a
speck in a hall crossed over 30 m. Sizes here are shares of the scene's extent (the largest
side of the bounding box of the groundtruth positions, else of the estimate's), clamped so
that a camera standing still or a building-sized run stays legible. The 3D view's eye is
placed at a distance that is also a multiple of the extent (:mod:`.blueprint`), so these
sizes look the same on screen from a desk to a hall.
"""

from typing import NamedTuple

import numpy as np

MIN_EXTENT_M = 0.1  # a camera that barely moves still looks at a scene about this size
FRUSTUM_SHARE = 0.12
FRUSTUM_RANGE_M = (0.03, 3.0)
KEYFRAME_SHARE = 0.006
KEYFRAME_RANGE_M = (0.0015, 0.15)


class SceneSizes(NamedTuple):
    frustum_depth: float  # Pinhole image_plane_distance, metres
    keyframe_radius: float  # keyframe markers, metres


def extent(positions: np.ndarray) -> float:
    """The largest side of the bounding box of ``positions`` ``(N, 3)``, 0 for none."""
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    return float(np.ptp(positions, axis=0).max()) if len(positions) else 0.0


def scene_sizes(scene_extent: float) -> SceneSizes:
    scene_extent = max(scene_extent, MIN_EXTENT_M)
    return SceneSizes(
        float(np.clip(FRUSTUM_SHARE * scene_extent, *FRUSTUM_RANGE_M)),
        float(np.clip(KEYFRAME_SHARE * scene_extent, *KEYFRAME_RANGE_M)),
    )
