"""Real ROS 1 and ROS 2 bags written with rosbags' writers, as the tests' input.

``write_tum_bag`` writes a TUM folder as TUM's own bags hold it: colour rgb8 on
``/camera/rgb/image_color``, depth 32FC1 metres on ``/camera/depth/image``, camera infos
(ROS's default intrinsics) on ``/camera/rgb/camera_info`` and ``/camera/depth/camera_info``,
and on ``/tf`` the motion capture ``/world -> /kinect`` plus a fixed ``/kinect ->
/openni_rgb_optical_frame``, chosen so that the chain composes to the folder's groundtruth.
"""

from pathlib import Path

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from viewer_slam.geometry.camera import TUM_DEPTH_FACTOR
from viewer_slam.geometry.se3 import invert, make_pose, pose_to_tq
from viewer_slam.geometry.trajectory import read_tum

ROS1_TF = "tf/msg/tfMessage"  # the type name in TUM's (ROS Fuerte) bags
ROS2_TF = "tf2_msgs/msg/TFMessage"
OPTICAL_FRAME = "/openni_rgb_optical_frame"
KINECT_TO_OPTICAL = make_pose(
    Rotation.from_rotvec(np.array([0.3, -1.2, 0.5])).as_matrix(), np.array([0.02, -0.05, 0.1])
)


class BagWriter:
    """One bag being written: ``add(topic, msgtype, stamp_ns, message)`` with connections made on first use."""

    def __init__(self, path: Path, ros: int):
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore

        self.ros = ros
        self.typestore = get_typestore(Stores.ROS1_NOETIC if ros == 1 else Stores.ROS2_HUMBLE)
        if ros == 1:
            self.typestore.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", ROS1_TF))
            from rosbags.rosbag1 import Writer

            self._writer = Writer(path)
        else:
            from rosbags.rosbag2 import Writer

            self._writer = Writer(path, version=9)
        self._connections = {}
        self.types = self.typestore.types

    def __enter__(self):
        self._writer.open()
        return self

    def __exit__(self, *exc):
        self._writer.close()

    def header(self, stamp_ns: int, frame_id: str):
        stamp = self.types["builtin_interfaces/msg/Time"](sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
        extra = {"seq": 0} if self.ros == 1 else {}
        return self.types["std_msgs/msg/Header"](stamp=stamp, frame_id=frame_id, **extra)

    def add(self, topic: str, msgtype: str, stamp_ns: int, message) -> None:
        if topic not in self._connections:
            self._connections[topic] = self._writer.add_connection(topic, msgtype, typestore=self.typestore)
        serialize = self.typestore.serialize_ros1 if self.ros == 1 else self.typestore.serialize_cdr
        self._writer.write(self._connections[topic], stamp_ns, serialize(message, msgtype))

    def image(self, topic: str, stamp_ns: int, frame_id: str, pixels: np.ndarray, encoding: str) -> None:
        height, width = pixels.shape[:2]
        data = np.ascontiguousarray(pixels).view(np.uint8).reshape(-1)
        message = self.types["sensor_msgs/msg/Image"](
            header=self.header(stamp_ns, frame_id),
            height=height,
            width=width,
            encoding=encoding,
            is_bigendian=0,
            step=len(data) // height,
            data=data,
        )
        self.add(topic, "sensor_msgs/msg/Image", stamp_ns, message)

    def camera_info(
        self,
        topic: str,
        stamp_ns: int,
        frame_id: str,
        width: int,
        height: int,
        k: tuple[float, float, float, float],
        distortion=(0.0,) * 5,
    ) -> None:
        fx, fy, cx, cy = k
        matrices = {
            "d": np.array(distortion, float),
            "k": np.array([fx, 0, cx, 0, fy, cy, 0, 0, 1], float),
            "r": np.eye(3).reshape(-1),
            "p": np.array([fx, 0, cx, 0, 0, fy, cy, 0, 0, 0, 1, 0], float),
        }
        if self.ros == 1:
            matrices = {name.upper(): value for name, value in matrices.items()}
        roi = self.types["sensor_msgs/msg/RegionOfInterest"](
            x_offset=0, y_offset=0, height=0, width=0, do_rectify=False
        )
        message = self.types["sensor_msgs/msg/CameraInfo"](
            header=self.header(stamp_ns, frame_id),
            height=height,
            width=width,
            distortion_model="plumb_bob",
            binning_x=0,
            binning_y=0,
            roi=roi,
            **matrices,
        )
        self.add(topic, "sensor_msgs/msg/CameraInfo", stamp_ns, message)

    def transform(self, stamp_ns: int, parent: str, child: str, pose: np.ndarray) -> None:
        t, q = pose_to_tq(pose)
        vector = self.types["geometry_msgs/msg/Vector3"](x=t[0], y=t[1], z=t[2])
        rotation = self.types["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3])
        stamped = self.types["geometry_msgs/msg/TransformStamped"](
            header=self.header(stamp_ns, parent),
            child_frame_id=child,
            transform=self.types["geometry_msgs/msg/Transform"](translation=vector, rotation=rotation),
        )
        msgtype = ROS1_TF if self.ros == 1 else ROS2_TF
        self.add("/tf", msgtype, stamp_ns, self.types[msgtype](transforms=[stamped]))


def nanoseconds(stamp: str) -> int:
    """A listing's decimal stamp as integer nanoseconds, without float rounding."""
    whole, _, fraction = stamp.partition(".")
    return int(whole) * 10**9 + int(fraction.ljust(9, "0")[:9])


def listing(folder: Path, name: str) -> list[tuple[str, str]]:
    return [
        tuple(line.split()[:2])
        for line in (folder / name).read_text().splitlines()
        if line.strip() and not line.startswith("#")
    ]


def write_tum_bag(folder: Path, path: Path, ros: int = 1) -> Path:
    """The TUM folder ``folder`` as a bag at ``path`` (see the module docstring)."""
    rgb, depth = listing(folder, "rgb.txt"), listing(folder, "depth.txt")
    first, last = nanoseconds(rgb[0][0]), nanoseconds(rgb[-1][0])
    with BagWriter(path, ros) as bag:
        for stamp, name in rgb:
            image = cv2.cvtColor(cv2.imread(str(folder / name), cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
            bag.image("/camera/rgb/image_color", nanoseconds(stamp), OPTICAL_FRAME, image, "rgb8")
            bag.camera_info(
                "/camera/rgb/camera_info",
                nanoseconds(stamp),
                OPTICAL_FRAME,
                image.shape[1],
                image.shape[0],
                (525.0, 525.0, 319.5, 239.5),
            )
        for stamp, name in depth:
            metres = (cv2.imread(str(folder / name), cv2.IMREAD_UNCHANGED) / TUM_DEPTH_FACTOR).astype(np.float32)
            metres[metres == 0] = np.nan  # as the OpenNI driver publishes no measurement
            bag.image("/camera/depth/image", nanoseconds(stamp), "/openni_depth_optical_frame", metres, "32FC1")
            bag.camera_info(
                "/camera/depth/camera_info",
                nanoseconds(stamp),
                "/openni_depth_optical_frame",
                metres.shape[1],
                metres.shape[0],
                (570.3, 570.3, 319.5, 239.5),
            )
        groundtruth_lines = [
            line.split()[0]
            for line in (folder / "groundtruth.txt").read_text().splitlines()
            if line.strip() and not line.startswith("#")
        ]
        truth = read_tum(folder / "groundtruth.txt")
        for stamp, pose in zip(groundtruth_lines, truth.poses):
            ns = nanoseconds(stamp)
            if first - 10**8 <= ns <= last + 10**8:  # the mocap around the frames, not the whole excerpt
                bag.transform(ns, "/world", "/kinect", pose @ invert(KINECT_TO_OPTICAL))
                bag.transform(ns, "/kinect", OPTICAL_FRAME, KINECT_TO_OPTICAL)
    return path


def write_poses(bag: BagWriter, topic: str, poses, start_ns: int = 5 * 10**9, step_ns: int = 10**8) -> None:
    """``poses`` as PoseStamped messages on ``topic``, ``step_ns`` apart from ``start_ns``."""
    types = bag.types
    for k, pose in enumerate(poses):
        (x, y, z), (qx, qy, qz, qw) = pose_to_tq(pose)
        stamp = start_ns + k * step_ns
        message = types["geometry_msgs/msg/PoseStamped"](
            header=bag.header(stamp, "map"),
            pose=types["geometry_msgs/msg/Pose"](
                position=types["geometry_msgs/msg/Point"](x=x, y=y, z=z),
                orientation=types["geometry_msgs/msg/Quaternion"](x=qx, y=qy, z=qz, w=qw),
            ),
        )
        bag.add(topic, "geometry_msgs/msg/PoseStamped", stamp, message)
