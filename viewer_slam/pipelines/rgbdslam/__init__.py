"""The RGB-D SLAM pipeline (Endres et al.), registered as ``rgbdslam``."""

from .params import RgbdSlamParams
from .pipeline import RgbdSlam

PIPELINE = RgbdSlam

__all__ = ["PIPELINE", "RgbdSlam", "RgbdSlamParams"]
