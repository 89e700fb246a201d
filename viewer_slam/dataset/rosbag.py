"""ROS bags as sequences: a ROS 1 ``.bag`` file or a ROS 2 bag folder, read with rosbags.

Topics are found by message type unless they are named. Colour and depth are the
``sensor_msgs/Image`` topics whose encoding is a colour one (rgb8, bgr8, rgba8, bgra8,
mono8) or a depth one (16UC1 or mono16 in millimetres, 32FC1 in metres, NaN for no
measurement); when several qualify, the one whose name says ``rgb``/``color`` (``depth``)
is taken. The camera info is the ``sensor_msgs/CameraInfo`` topic beside the colour topic.
Colour and depth are paired by header stamp exactly as a TUM folder's listings are, so
TUM's own bags give the frames of their folders.

The camera is the one a TUM folder of the same name would get (the published freiburg
calibration), else the camera info's, else ROS's default. The groundtruth is a file given,
else a pose topic given, else the tf chain from the root of the tf tree to the colour
image's frame when a transform on it moves (the motion capture in TUM's bags). As the
groundtruth of `viewslam evaluate` (:func:`open_groundtruth`), a bag may also be one of
poses alone; as an estimate (:func:`bag_poses`), its pose topic is read.

rosbags is imported when a bag is opened, so commands that never open one never load it.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InputError
from ..geometry.association import associate
from ..geometry.camera import Camera
from ..geometry.interpolation import interpolate_poses
from ..geometry.se3 import pose_from_tq
from ..geometry.trajectory import Trajectory, pose_problem
from ..geometry.trajectory_formats import read_trajectory
from .cameras import ASSOCIATION_MAX_DIFFERENCE_S, ROS_DEFAULT_CAMERA, freiburg_camera
from .frame import Frame, TimedFrames, select_frames

if TYPE_CHECKING:
    from rosbags.highlevel import AnyReader

log = logging.getLogger(__name__)

IMAGE = "sensor_msgs/msg/Image"
CAMERA_INFO = "sensor_msgs/msg/CameraInfo"
TF_TYPES = ("tf2_msgs/msg/TFMessage", "tf/msg/tfMessage")
POSE_TYPES = (
    "geometry_msgs/msg/PoseStamped",
    "geometry_msgs/msg/PoseWithCovarianceStamped",
    "geometry_msgs/msg/TransformStamped",
    "nav_msgs/msg/Odometry",
)
# Encoding -> OpenCV's conversion to RGB, by name (None: already RGB); OpenCV loads only for
# frames, so `viewslam evaluate` reads a bag's poses without it.
COLOUR_ENCODINGS = {
    "rgb8": None,
    "bgr8": "COLOR_BGR2RGB",
    "rgba8": "COLOR_RGBA2RGB",
    "bgra8": "COLOR_BGRA2RGB",
    "mono8": "COLOR_GRAY2RGB",
}
# Encoding -> (pixel type, metres per unit).
DEPTH_ENCODINGS = {"16UC1": ("u2", 1e-3), "mono16": ("u2", 1e-3), "32FC1": ("f4", 1.0)}
MAX_DEPTH_M = 1000.0
"""A depth beyond this is no sensor's measurement but damaged data (a flipped exponent bit)."""
_CHANNELS = {"rgb8": 3, "bgr8": 3, "rgba8": 4, "bgra8": 4, "mono8": 1}
_TOPIC_WORDS = {"colour": ("rgb", "color", "colour"), "depth": ("depth",)}


def is_bag(path: Path) -> bool:
    """A ROS 1 bag file (``.bag``) or a ROS 2 bag folder (with ``metadata.yaml``)."""
    path = Path(path)
    return (path.suffix == ".bag" and path.is_file()) or (path / "metadata.yaml").is_file()


@dataclass(frozen=True)
class _Stream:
    """One image topic of the bag: each kept message's header stamp (ns) and log time (ns)."""

    topic: str
    encoding: str
    stamps_ns: np.ndarray
    log_times_ns: np.ndarray


class BagSequence(TimedFrames):
    """A ROS bag as a :class:`~viewer_slam.dataset.frame.Sequence` (the interface of TumSequence).

    ``timestamps`` are the paired colour header stamps, ``depth_timestamps`` the depth stamps
    paired with them. Frames are read lazily, in one pass over the bag.
    """

    accelerometer = None

    def __init__(self, path: Path, camera: Camera, colour: _Stream, depth: _Stream, groundtruth: Trajectory | None):
        self.path = path
        self.name = path.resolve().name.removesuffix(".bag")
        self.camera = camera
        self.groundtruth = groundtruth
        self.topics = (colour.topic, depth.topic)
        order_c, order_d = np.argsort(colour.stamps_ns, kind="stable"), np.argsort(depth.stamps_ns, kind="stable")
        rgb_index, depth_index = associate(
            _seconds(colour.stamps_ns[order_c]), _seconds(depth.stamps_ns[order_d]), 0.0, ASSOCIATION_MAX_DIFFERENCE_S
        )
        if len(rgb_index) == 0:
            raise InputError.at(
                path,
                f"no colour image on {colour.topic} has a depth image on {depth.topic} "
                f"within {ASSOCIATION_MAX_DIFFERENCE_S} s",
            )
        self._colour, self._depth = colour, depth
        self._colour_rows, self._depth_rows = order_c[rgb_index], order_d[depth_index]
        self.timestamps = _seconds(colour.stamps_ns[self._colour_rows])
        self.depth_timestamps = _seconds(depth.stamps_ns[self._depth_rows])

    def frame(self, index: int) -> Frame:
        """The ``index``-th paired frame, read from the bag now."""
        return next(self._read([index]))

    def frames(self, max_frames: int | None = None, stride: int = 1) -> Iterator[Frame]:
        return self._read(select_frames(len(self), max_frames, stride))

    def _read(self, indices: Iterable[int]) -> Iterator[Frame]:
        """The frames at ``indices`` in that order, from one pass over the messages they need."""
        indices = list(indices)
        if not indices:
            return
        wanted = {(self._colour.topic, int(self._colour.stamps_ns[self._colour_rows[i]])): (i, 0) for i in indices}
        wanted |= {(self._depth.topic, int(self._depth.stamps_ns[self._depth_rows[i]])): (i, 1) for i in indices}
        colour_times = self._colour.log_times_ns[self._colour_rows[indices]]
        depth_times = self._depth.log_times_ns[self._depth_rows[indices]]
        # Log times pick the messages to decode; header stamps (what frames are keyed by) confirm them.
        needed = {(self._colour.topic, int(t)) for t in colour_times} | {
            (self._depth.topic, int(t)) for t in depth_times
        }
        log_times = np.concatenate([colour_times, depth_times])
        parts: dict[int, list] = {}
        position = 0
        with _open_reader(self.path) as reader:
            connections = [c for c in reader.connections if c.topic in self.topics]
            for connection, log_time, raw in _messages(
                self.path, reader, connections, int(log_times.min()), int(log_times.max()) + 1
            ):
                if (connection.topic, log_time) not in needed:
                    continue
                message = _deserialize(self.path, reader, raw, connection)
                key = wanted.get((connection.topic, _stamp_ns(message.header.stamp)))
                if key is None:
                    continue
                index, part = key
                parts.setdefault(index, [None, None])[part] = message
                while position < len(indices) and None not in parts.get(indices[position], [None]):
                    rgb, depth = parts.pop(indices[position])
                    yield self._frame(indices[position], rgb, depth)
                    position += 1
                if position == len(indices):
                    return
        missing = indices[position]
        raise InputError.at(
            self.path, f"frame {missing} ({self.timestamps[missing]:.6f} s) was not found again in the bag"
        )

    def _frame(self, index: int, rgb_message, depth_message) -> Frame:
        try:
            rgb, depth = _colour_image(rgb_message), _depth_image(depth_message)
        except (KeyError, ValueError) as error:  # an encoding that changed, data that do not fill the image
            raise InputError.at(
                self.path,
                f"frame {index} ({self.timestamps[index]:.6f} s): malformed image ({type(error).__name__}: {error})",
            ) from None
        far = np.flatnonzero(depth.ravel() > MAX_DEPTH_M)
        if len(far):
            row, col = divmod(int(far[0]), depth.shape[1])
            raise InputError.at(
                self.path,
                f"frame {index} ({self.timestamps[index]:.6f} s): {self.topics[1]}: depth "
                f"{depth[row, col]:.6g} m at pixel ({col}, {row}) is beyond any depth sensor's range "
                f"({MAX_DEPTH_M:g} m): damaged data",
            )
        expected = (self.camera.height, self.camera.width)
        for topic, image in zip(self.topics, (rgb, depth)):
            if image.shape[:2] != expected:
                raise InputError.at(
                    self.path,
                    f"{topic}: image is {image.shape[1]}x{image.shape[0]} but the "
                    f"camera is {self.camera.width}x{self.camera.height}",
                )
        return Frame(index=index, timestamp=float(self.timestamps[index]), rgb=rgb, depth=depth)


def open_bag(
    path: Path,
    *,
    rgb_topic: str | None = None,
    depth_topic: str | None = None,
    camera_info_topic: str | None = None,
    groundtruth: Path | None = None,
    groundtruth_topic: str | None = None,
) -> BagSequence:
    """Open a ROS bag as a sequence (see the module docstring for how topics are found).

    Any problem (not a bag, no image topic, a named topic that is missing or of the wrong
    type) is an :class:`InputError` naming the bag and the problem.
    """
    path = Path(path)
    if not path.exists():
        raise InputError.at(path, "no such bag")
    with _open_reader(path) as reader:
        colour = _image_stream(path, reader, rgb_topic, "colour", COLOUR_ENCODINGS, "--rgb-topic")
        depth = _image_stream(path, reader, depth_topic, "depth", DEPTH_ENCODINGS, "--depth-topic")
        camera = _camera(path, reader, colour, camera_info_topic)
        trajectory: Trajectory | None
        if groundtruth is not None:
            trajectory = read_trajectory(groundtruth)[0]
        elif groundtruth_topic is not None:
            trajectory = _pose_topic(path, reader, groundtruth_topic)
        else:
            trajectory = _tf_groundtruth(path, reader, _frame_id(path, reader, colour.topic))
    return BagSequence(path, camera, colour, depth, trajectory)


def open_groundtruth(path: Path, *, groundtruth_topic: str | None = None) -> tuple[Trajectory, BagSequence | None]:
    """A bag as the groundtruth to score against, and the bag as a sequence when it has images.

    The poses are those of ``groundtruth_topic`` (a pose topic), else those a recording of the
    bag gets (the tf chain to the colour camera), else the bag's only pose topic; a bag with
    none of these is an :class:`InputError`. The sequence (None for a bag of poses alone)
    gives the frames whose span the coverage is measured over, as a TUM folder's do.
    """
    path = Path(path)
    if not path.exists():
        raise InputError.at(path, "no such bag")
    with _open_reader(path) as reader:
        has_images = any(connection.msgtype == IMAGE for connection in reader.connections)
    sequence = open_bag(path, groundtruth_topic=groundtruth_topic) if has_images else None
    if sequence is not None and sequence.groundtruth is not None:
        return sequence.groundtruth, sequence
    return bag_poses(
        path,
        groundtruth_topic,
        option="--groundtruth-topic",
        missing=" and no moving tf chain to the colour camera" if has_images else "",
    ), sequence


def bag_poses(
    path: Path, topic: str | None = None, *, option: str = "--groundtruth-topic", missing: str = ""
) -> Trajectory:
    """The poses of the bag's pose topic ``topic``, or of its only one; the ``option`` that names
    one is in the error (with ``missing``, what else was looked for) when there is none or several."""
    path = Path(path)
    if not path.exists():
        raise InputError.at(path, "no such bag")
    with _open_reader(path) as reader:
        if topic is not None:
            return _pose_topic(path, reader, topic, option)
        topics = list(dict.fromkeys(c.topic for c in reader.connections if c.msgtype in POSE_TYPES))
        if len(topics) != 1:
            problem = "no pose topic" if not topics else f"several pose topics ({', '.join(topics)})"
            raise InputError.at(path, f"{problem}{missing}; name one with {option}; topics: {_topic_list(reader)}")
        return _pose_topic(path, reader, topics[0], option)


@contextmanager
def _open_reader(path: Path) -> Iterator[AnyReader]:
    """An open AnyReader; types without definitions in the bag come from rosbags' latest store."""
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.typesys import Stores, get_typestore

    try:
        reader = AnyReader([path], default_typestore=get_typestore(Stores.LATEST))
        reader.open()
    except (AnyReaderError, OSError, ValueError) as error:
        raise InputError.at(path, f"not a readable ROS bag: {' '.join(str(error).split())}") from None
    try:
        yield reader
    finally:
        reader.close()


def _messages(path: Path, reader: AnyReader, connections, start: int | None = None, stop: int | None = None):
    """The messages of ``connections`` (none for an empty list: rosbags reads every topic then)."""
    if not connections:
        return
    try:
        yield from reader.messages(connections=connections, start=start, stop=stop)
    except Exception as error:  # rosbags raises its readers' own errors on corrupt chunks
        raise InputError.at(path, f"cannot read the bag: {' '.join(str(error).split())}") from None


def _deserialize(path: Path, reader: AnyReader, raw: bytes, connection):
    from rosbags.highlevel import AnyReaderError

    try:
        return reader.deserialize(raw, connection.msgtype)
    except AnyReaderError as error:
        raise InputError.at(path, f"{connection.topic}: cannot decode a {connection.msgtype}: {error}") from None


def _connections(reader: AnyReader, topic: str) -> list:
    return [c for c in reader.connections if c.topic == topic]


def _first_message(path: Path, reader: AnyReader, topic: str):
    for connection, _, raw in _messages(path, reader, _connections(reader, topic)):
        return _deserialize(path, reader, raw, connection)
    return None


def _topic_list(reader: AnyReader) -> str:
    topics = dict.fromkeys(f"{c.topic} ({c.msgtype})" for c in reader.connections)
    return ", ".join(topics) or "none"


def _image_stream(path: Path, reader: AnyReader, topic: str | None, kind: str, encodings: dict, option: str) -> _Stream:
    """The colour or depth topic, named or found, with its messages' stamps."""
    if topic is not None:
        connections = _connections(reader, topic)
        if not connections:
            raise InputError.at(path, f"{option} {topic}: no such topic; topics: {_topic_list(reader)}")
        if connections[0].msgtype != IMAGE:
            raise InputError.at(path, f"{option} {topic}: is {connections[0].msgtype}, not an image ({IMAGE})")
        candidates = [topic]
    else:
        candidates = list(dict.fromkeys(c.topic for c in reader.connections if c.msgtype == IMAGE))
    encoded = {name: getattr(_first_message(path, reader, name), "encoding", None) for name in candidates}
    suitable = [name for name, encoding in encoded.items() if encoding in encodings]
    if topic is not None and not suitable:
        raise InputError.at(
            path, f"{option} {topic}: encoding {encoded[topic]!r} is not a {kind} encoding ({', '.join(encodings)})"
        )
    if len(suitable) > 1:
        suitable = [name for name in suitable if any(word in name.lower() for word in _TOPIC_WORDS[kind])] or suitable
    if not suitable:
        raise InputError.at(
            path, f"no {kind} image topic ({IMAGE} in {', '.join(encodings)}); topics: {_topic_list(reader)}"
        )
    if len(suitable) > 1:
        raise InputError.at(path, f"several {kind} image topics ({', '.join(suitable)}); choose one with {option}")
    chosen = suitable[0]
    stamps, log_times = [], []
    for connection, log_time, raw in _messages(path, reader, _connections(reader, chosen)):
        stamps.append(_stamp_ns(_deserialize(path, reader, raw, connection).header.stamp))
        log_times.append(log_time)
    return _Stream(chosen, str(encoded[chosen]), np.array(stamps, dtype=np.int64), np.array(log_times, dtype=np.int64))


def _frame_id(path: Path, reader: AnyReader, topic: str) -> str:
    return _first_message(path, reader, topic).header.frame_id


def _camera(path: Path, reader: AnyReader, colour: _Stream, topic: str | None) -> Camera:
    published = freiburg_camera(path.resolve().name)
    if published is not None:
        return published
    if topic is not None:
        connections = _connections(reader, topic)
        if not connections or connections[0].msgtype != CAMERA_INFO:
            found = connections[0].msgtype if connections else "no such topic"
            raise InputError.at(path, f"--camera-info-topic {topic}: {found}, not a {CAMERA_INFO}")
    else:
        infos = list(dict.fromkeys(c.topic for c in reader.connections if c.msgtype == CAMERA_INFO))
        beside = [name for name in infos if name.rsplit("/", 1)[0] == colour.topic.rsplit("/", 1)[0]]
        candidates = beside if len(beside) == 1 else infos
        topic = candidates[0] if len(candidates) == 1 else None
    info = _first_message(path, reader, topic) if topic is not None else None
    if info is None:
        log.warning(
            "%s: no camera info topic beside %s; using the ROS default camera (fx=fy=525, cx=319.5, cy=239.5)",
            path,
            colour.topic,
        )
        return ROS_DEFAULT_CAMERA
    k = np.asarray(getattr(info, "k", getattr(info, "K", None)), dtype=np.float64)
    distortion = tuple(float(v) for v in getattr(info, "d", getattr(info, "D", ())))[:5]
    if k.shape != (9,) or k[0] <= 0 or k[4] <= 0:
        raise InputError.at(path, f"{topic}: camera info has no focal length (K = {k.tolist()})")
    fx, fy, cx, cy = (float(k[i]) for i in (0, 4, 2, 5))
    return Camera.checked(
        {
            "fx": fx,
            "fy": fy,
            "cx": cx,
            "cy": cy,
            "width": int(info.width),
            "height": int(info.height),
            "distortion": distortion + (0.0,) * (5 - len(distortion)),
        },
        f"{path}: {topic}",
    )


def _pose_topic(path: Path, reader: AnyReader, topic: str, option: str = "--groundtruth-topic") -> Trajectory:
    """Poses of a PoseStamped, PoseWithCovarianceStamped, TransformStamped or Odometry topic."""
    connections = _connections(reader, topic)
    if not connections or connections[0].msgtype not in POSE_TYPES:
        found = connections[0].msgtype if connections else "no such topic"
        raise InputError.at(path, f"{option} {topic}: {found}, not one of {', '.join(POSE_TYPES)}")
    stamps, poses = [], []
    for connection, _, raw in _messages(path, reader, connections):
        message = _deserialize(path, reader, raw, connection)
        pose = getattr(message, "transform", None) or message.pose
        pose = getattr(pose, "pose", pose)  # the ...WithCovariance wrappers
        stamps.append(_stamp_ns(message.header.stamp))
        poses.append(
            _pose(
                path,
                topic,
                stamps[-1],
                getattr(pose, "translation", None) or pose.position,
                getattr(pose, "rotation", None) or pose.orientation,
            )
        )
    return _trajectory(stamps, poses)


def _tf_groundtruth(path: Path, reader: AnyReader, frame: str) -> Trajectory | None:
    """``T_root_frame`` over time from the tf tree, or None when nothing on the chain moves.

    The moving transform with the most samples sets the stamps; other moving ones are
    interpolated at them (stamps they do not cover are dropped), fixed ones composed as they are.
    """
    samples: dict[str, tuple[str, list]] = {}  # child -> (parent, [(stamp ns, 4x4)])
    tf = [c for c in reader.connections if c.msgtype in TF_TYPES]
    for connection, _, raw in _messages(path, reader, tf):
        for transform in _deserialize(path, reader, raw, connection).transforms:
            child, parent = transform.child_frame_id.strip("/"), transform.header.frame_id.strip("/")
            entry = samples.setdefault(child, (parent, []))
            if entry[0] == parent:
                stamp = _stamp_ns(transform.header.stamp)
                entry[1].append(
                    (
                        stamp,
                        _pose(
                            path, connection.topic, stamp, transform.transform.translation, transform.transform.rotation
                        ),
                    )
                )
    chain: list[Trajectory] = []
    frame, seen = frame.strip("/"), set()
    while frame in samples and frame not in seen:  # up to the root
        seen.add(frame)
        parent, timed_poses = samples[frame]
        chain.append(_trajectory([stamp for stamp, _ in timed_poses], [pose for _, pose in timed_poses]))
        frame = parent
    moving = [edge for edge in chain if not (edge.poses == edge.poses[0]).all()]
    if not moving:
        return None
    reference = max(moving, key=len)
    poses, covered = np.broadcast_to(np.eye(4), (len(reference), 4, 4)), np.ones(len(reference), dtype=bool)
    for edge in reversed(chain):  # root first
        if edge is reference:
            at = edge.poses
        elif any(edge is other for other in moving):
            at, inside = interpolate_poses(edge, reference.timestamps)
            covered &= inside
        else:
            at = edge.poses[-1]
        poses = poses @ at
    return Trajectory(reference.timestamps[covered], poses[covered])


def _trajectory(stamps_ns: list[int], poses: list[np.ndarray]) -> Trajectory:
    """A trajectory in time order, one pose per stamp (the last one of a repeated stamp)."""
    stamps = np.array(stamps_ns, dtype=np.int64)
    order = np.argsort(stamps, kind="stable")
    stamps, stacked = stamps[order], np.array(poses).reshape(-1, 4, 4)[order]
    last = np.append(stamps[1:] != stamps[:-1], True)
    return Trajectory(_seconds(stamps[last]), stacked[last])


def _pose(path: Path, topic: str, stamp_ns: int, translation, rotation) -> np.ndarray:
    """The pose of a message on ``topic``, checked as a trajectory file's poses are."""
    t = [translation.x, translation.y, translation.z]
    q = [rotation.x, rotation.y, rotation.z, rotation.w]
    problem = pose_problem(t, q)
    if problem is not None:
        raise InputError.at(path, f"{topic} at {stamp_ns / 1e9:.6f} s: {problem}")
    return pose_from_tq(np.array(t), np.array(q))


def _stamp_ns(stamp) -> int:
    return int(stamp.sec) * 10**9 + int(stamp.nanosec)


def _seconds(stamps_ns: np.ndarray) -> np.ndarray:
    """Exact to the nearest double: integer nanoseconds divided as integers."""
    return np.array([int(ns) / 10**9 for ns in stamps_ns], dtype=np.float64)


def _pixels(message, dtype: str, channels: int) -> np.ndarray:
    """The image's pixels ``(H, W[, C])``, honouring the row stride and byte order."""
    pixel = np.dtype(dtype).newbyteorder(">" if message.is_bigendian else "<")
    rows = np.asarray(message.data, dtype=np.uint8).reshape(message.height, message.step)
    values = rows[:, : message.width * channels * pixel.itemsize].copy().view(pixel)
    shape = (message.height, message.width) if channels == 1 else (message.height, message.width, channels)
    return values.reshape(shape)


def _colour_image(message) -> np.ndarray:
    image = _pixels(message, "u1", _CHANNELS[message.encoding])
    conversion = COLOUR_ENCODINGS[message.encoding]
    if conversion is None:
        return np.ascontiguousarray(image)
    import cv2

    return cv2.cvtColor(image, getattr(cv2, conversion))


def _depth_image(message) -> np.ndarray:
    """Metres as float32, 0 where the sensor measured nothing: NaN, non-positive, or infinite
    (REP 118: +Inf too far, -Inf too near to measure)."""
    dtype, metres_per_unit = DEPTH_ENCODINGS[message.encoding]
    raw = _pixels(message, dtype, 1)
    depth = raw.astype(np.float32) if metres_per_unit == 1.0 else (raw * metres_per_unit).astype(np.float32)
    depth[~((depth > 0) & np.isfinite(depth))] = 0.0
    return depth
