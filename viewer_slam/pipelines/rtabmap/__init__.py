"""RTAB-Map (Labbé & Michaud): frame-to-map odometry, bag-of-words loop closure detection
with a Bayes filter under memory management, and a GTSAM pose graph."""

from .params import RtabmapParams
from .pipeline import Rtabmap

PIPELINE = Rtabmap

__all__ = ["PIPELINE", "Rtabmap", "RtabmapParams"]
