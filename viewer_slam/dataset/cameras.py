"""The cameras and pairing rule every RGB-D source shares: TUM's published calibrations, ROS's
default camera, and the colour/depth association window.

A TUM folder and a ROS bag of the same sequence must give the same frames and camera, so
both readers take these from here rather than from each other.
"""

import re

from ..geometry.camera import Camera

# TUM's associate.py window: a colour and a depth image at most this far apart form a frame.
ASSOCIATION_MAX_DIFFERENCE_S = 0.02

# Published with the dataset (cvg.cit.tum.de/data/datasets/rgbd-dataset/file_formats).
FREIBURG_CAMERAS = {
    "freiburg1": Camera(517.3, 516.5, 318.6, 255.3, 640, 480, distortion=(0.2624, -0.9531, -0.0054, 0.0026, 1.1633)),
    "freiburg2": Camera(520.9, 521.0, 325.1, 249.7, 640, 480, distortion=(0.2312, -0.7849, -0.0033, -0.0001, 0.9172)),
    "freiburg3": Camera(535.4, 539.2, 320.1, 247.6, 640, 480),
}
ROS_DEFAULT_CAMERA = Camera(525.0, 525.0, 319.5, 239.5, 640, 480)


def freiburg_camera(name: str) -> Camera | None:
    """The published calibration of the sensor a TUM name (folder or bag) says, if it says one."""
    match = re.search(r"freiburg[123]", name)
    return FREIBURG_CAMERAS[match.group(0)] if match else None
