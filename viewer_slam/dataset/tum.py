"""TUM RGB-D sequence folders: rgb.txt, depth.txt, groundtruth.txt, accelerometer.txt.

Colour and depth images are associated as TUM's ``associate.py rgb.txt depth.txt`` does
(greedy one-to-one, 0.02 s). Frames are read lazily from the PNG files, a few frames ahead
of the consumer on a background thread (PNG decoding releases the GIL), so decoding
overlaps with the processing of the frames before.
"""

import io
import logging
import struct
import warnings
import zlib
from collections import deque
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..geometry.association import associate
from ..geometry.camera import Camera
from ..geometry.trajectory import Trajectory, read_tum
from .cameras import ASSOCIATION_MAX_DIFFERENCE_S, ROS_DEFAULT_CAMERA, freiburg_camera
from .frame import Frame, TimedFrames, select_frames

log = logging.getLogger(__name__)

READ_AHEAD_FRAMES = 2

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@dataclass(frozen=True)
class _Listing:
    """One of TUM's ``timestamp value...`` text files, parsed."""

    stamps: np.ndarray
    values: list[list[str]]


class TumSequence(TimedFrames):
    """A TUM RGB-D folder as a :class:`~viewer_slam.dataset.frame.Sequence`.

    ``timestamps`` are the associated colour stamps (one per frame), ``depth_timestamps``
    the depth stamps paired with them.
    """

    def __init__(
        self,
        path: Path,
        camera: Camera,
        rgb: _Listing,
        depth: _Listing,
        groundtruth: Trajectory | None,
        accelerometer: np.ndarray | None,
    ):
        self.path = path
        self.name = path.resolve().name
        self.camera = camera
        self.groundtruth = groundtruth
        self.accelerometer = accelerometer
        rgb_index, depth_index = associate(rgb.stamps, depth.stamps, 0.0, ASSOCIATION_MAX_DIFFERENCE_S)
        if len(rgb_index) == 0:
            raise InputError.at(
                path / "rgb.txt",
                f"no colour image has a depth image within {ASSOCIATION_MAX_DIFFERENCE_S} s in depth.txt",
            )
        self.timestamps = rgb.stamps[rgb_index]
        self.depth_timestamps = depth.stamps[depth_index]
        self._rgb_files = [rgb.values[i][0] for i in rgb_index]
        self._depth_files = [depth.values[i][0] for i in depth_index]

    def frame(self, index: int) -> Frame:
        """The ``index``-th associated frame, read from disk now."""
        rgb_path, depth_path = self.path / self._rgb_files[index], self.path / self._depth_files[index]
        rgb = self._read_image(rgb_path, colour=True, size=self._size_check(rgb_path))
        raw_depth = self._read_image(depth_path, colour=False, size=self._size_check(depth_path))
        if raw_depth.dtype != np.uint16 or raw_depth.ndim != 2:
            raise InputError.at(
                depth_path,
                f"depth image must be single-channel 16-bit, found {raw_depth.dtype} with shape {raw_depth.shape}",
            )
        depth = depth_in_metres(raw_depth, self.camera.depth_factor)
        return Frame(index=index, timestamp=float(self.timestamps[index]), rgb=rgb, depth=depth)

    def frames(self, max_frames: int | None = None, stride: int = 1) -> Iterator[Frame]:
        indices = select_frames(len(self), max_frames, stride)
        pending: deque = deque()
        with ThreadPoolExecutor(1, thread_name_prefix="tum-reader") as reader:
            try:
                for index in indices:
                    pending.append(reader.submit(self.frame, index))
                    if len(pending) > READ_AHEAD_FRAMES:
                        yield pending.popleft().result()
                while pending:
                    yield pending.popleft().result()
            finally:
                for future in pending:
                    future.cancel()

    def check_images(self) -> None:
        """Refuse a missing, truncated or corrupt image among the frames without decoding any:
        each must exist, and a PNG have complete chunks that match their checksums."""
        for name in (*self._rgb_files, *self._depth_files):
            path = self.path / name
            if not _image_bytes(path):
                raise InputError.at(path, "not a readable image")

    def _size_check(self, path: Path) -> Callable[[int, int], None]:
        """Refuses (width, height) other than the camera's, naming the image at ``path``."""

        def check(width: int, height: int) -> None:
            if (width, height) != (self.camera.width, self.camera.height):
                raise InputError.at(
                    path,
                    f"image is {width}x{height} but the camera is "
                    f"{self.camera.width}x{self.camera.height} (add a camera.json)",
                )

        return check

    @staticmethod
    def _read_image(path: Path, colour: bool, size: Callable[[int, int], None]) -> np.ndarray:
        """An RGB (``colour``) or unchanged (depth) image. ``size`` checks the size the file
        announces before anything is decoded. Pillow decodes what it knows (PNG, JPEG, ...): it
        raises on damaged data where libpng and libjpeg print their own complaints on stderr;
        OpenCV the rest."""
        data = _image_bytes(path)
        image = _decode(path, data, colour, size)
        if image is not None:
            return image
        import cv2  # OpenCV loads only when images are read, not for listings and groundtruth

        flags = cv2.IMREAD_COLOR if colour else cv2.IMREAD_UNCHANGED
        image = cv2.imdecode(np.frombuffer(data, np.uint8), flags) if data else None
        if image is None:
            raise InputError.at(path, "not a readable image")
        size(image.shape[1], image.shape[0])
        return cv2.cvtColor(image, cv2.COLOR_BGR2RGB) if colour else image


def depth_in_metres(raw: np.ndarray, depth_factor: float) -> np.ndarray:
    """16-bit depth values in metres, float32, to the bit as ``(raw / depth_factor).astype(np.float32)``
    gives them, without the float64 image that this makes.

    Where float32 holds the factor exactly, dividing in float32 is that to the bit: a float32
    quotient rounded through float64 first is the same, as float64 has more than twice
    float32's digits and two more (Figueroa 1995). For other factors, a table of all 65,536
    values; it takes three times as long.
    """
    if float(np.float32(depth_factor)) == depth_factor:
        return np.divide(raw, np.float32(depth_factor), dtype=np.float32)
    return np.take(metres_per_unit(depth_factor), raw)


@cache
def metres_per_unit(depth_factor: float) -> np.ndarray:
    """Every 16-bit depth value in metres, float32, as ``(value / depth_factor).astype(np.float32)``
    gives it: a depth image is converted by one look-up per pixel."""
    return (np.arange(1 << 16) / depth_factor).astype(np.float32)


def _image_bytes(path: Path) -> bytes:
    """The bytes of the image at ``path``; a PNG's chunks checked complete and intact."""
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise InputError.at(path, "image listed in the sequence is missing") from None
    except OSError as error:
        raise InputError.at(path, f"cannot read image: {error.strerror}") from None
    if data.startswith(_PNG_SIGNATURE):
        _check_png(path, data)
    return data


def _decode(path: Path, data: bytes, colour: bool, size: Callable[[int, int], None]) -> np.ndarray | None:
    """Pixels decoded by Pillow once ``size`` accepts the header's: RGB uint8 for ``colour``, else
    as stored (16-bit depth as uint16); None for a format Pillow does not know."""
    from PIL import Image

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Image.DecompressionBombWarning)
        try:
            image: Image.Image = Image.open(io.BytesIO(data))
        except Image.UnidentifiedImageError:
            claimed = _formats_claiming(data)
            if claimed:  # its signature is a format Pillow reads: damaged, not for OpenCV (libjpeg would print)
                raise InputError.at(path, f"corrupt {claimed[0]} header") from None
            return None
        except Image.DecompressionBombError:  # more pixels than any camera has: never decoded
            raise InputError.at(path, "image announces more pixels than a camera may have") from None
        except (OSError, SyntaxError, ValueError, zlib.error) as error:
            raise InputError.at(path, f"corrupt image header ({error})") from None
    with image:
        size(*image.size)
        try:
            if colour and image.mode != "RGB":
                image = image.convert("RGB")
            pixels = np.asarray(image)
        except (OSError, SyntaxError, ValueError, zlib.error) as error:
            raise InputError.at(path, f"corrupt {image.format or 'image'} ({error})") from None
    return pixels.astype(pixels.dtype.newbyteorder("="), copy=False)


def _formats_claiming(data: bytes) -> list[str]:
    """The formats Pillow knows whose signature ``data`` begins with."""
    from PIL import Image

    Image.init()
    claimed = []
    for name, (_, accept) in Image.OPEN.items():
        try:
            if accept is not None and accept(data[:16]):
                claimed.append(name)
        except (struct.error, IndexError, ValueError):  # a prefix too short for the signature it checks
            continue
    return claimed


def _check_png(path: Path, data: bytes) -> None:
    """Refuse a truncated or corrupt PNG with the chunk at fault named: every chunk must be
    complete, match its CRC, and the last must be IEND."""
    offset = len(_PNG_SIGNATURE)
    while offset + 12 <= len(data):
        length, kind = struct.unpack(">I4s", data[offset : offset + 8])
        end = offset + 12 + length
        if end > len(data):
            break
        (crc,) = struct.unpack(">I", data[end - 4 : end])
        if zlib.crc32(data[offset + 4 : end - 4]) != crc:
            raise InputError.at(path, f"corrupt PNG (bad checksum of its {kind.decode('latin-1')} chunk)")
        if kind == b"IEND":
            return
        offset = end
    raise InputError.at(path, "truncated PNG")


def open_tum(path: Path) -> TumSequence:
    """Open a TUM RGB-D folder; :class:`InputError` if it is not one (any source:
    :func:`~viewer_slam.dataset.sources.open_source`)."""
    path = Path(path)
    if not path.is_dir():
        raise InputError.at(path, "no such folder" if not path.exists() else "not a folder")
    for required in ("rgb.txt", "depth.txt"):
        if not (path / required).is_file():
            raise InputError.at(path, f"not a TUM RGB-D sequence (no {required})")
    groundtruth_path = path / "groundtruth.txt"
    accelerometer_path = path / "accelerometer.txt"
    sequence = TumSequence(
        path=path,
        camera=_camera_for(path),
        rgb=_read_listing(path / "rgb.txt", value_fields=1),
        depth=_read_listing(path / "depth.txt", value_fields=1),
        groundtruth=read_tum(groundtruth_path) if groundtruth_path.is_file() else None,
        accelerometer=_accelerations(accelerometer_path) if accelerometer_path.is_file() else None,
    )
    groundtruth = sequence.groundtruth
    if groundtruth is not None and len(sequence.frames_outside_groundtruth()) == len(sequence):
        log.warning(
            "%s: no frame lies within the groundtruth's time span (frames %.3f..%.3f s, groundtruth "
            "%.3f..%.3f s); nothing can be evaluated",
            groundtruth_path,
            sequence.timestamps[0],
            sequence.timestamps[-1],
            groundtruth.timestamps[0],
            groundtruth.timestamps[-1],
        )
    return sequence


def _camera_for(path: Path) -> Camera:
    """camera.json, else the published calibration named by the folder, else ROS's default."""
    if (path / "camera.json").is_file():
        return Camera.load(path / "camera.json")
    camera = freiburg_camera(path.resolve().name)
    if camera is not None:
        return camera
    log.warning(
        "%s: no camera.json and no freiburg1/2/3 in the folder name; using the ROS default "
        "camera (fx=fy=525, cx=319.5, cy=239.5)",
        path,
    )
    return ROS_DEFAULT_CAMERA


def _read_listing(path: Path, value_fields: int) -> _Listing:
    """Lines ``timestamp v1 .. vk``, ``#`` comments skipped; InputError with the line number."""
    try:
        text = path.read_text(encoding="utf-8-sig")  # a byte-order mark is not part of the first line
    except (OSError, UnicodeDecodeError) as error:
        raise InputError.at(path, f"cannot read: {error}") from None
    stamps, values = [], []
    for number, line in enumerate(text.splitlines(), start=1):
        fields = line.replace(",", " ").split()
        if not fields or fields[0].startswith("#"):
            continue
        if len(fields) != 1 + value_fields:
            raise InputError.at(path, f"expected {1 + value_fields} fields, found {len(fields)}", number)
        try:
            stamp = float(fields[0])
        except ValueError:
            raise InputError.at(path, f"timestamp {fields[0]!r} is not a number", number) from None
        if not np.isfinite(stamp):
            raise InputError.at(path, "timestamp is NaN or infinite", number)
        stamps.append(stamp)
        values.append(fields[1:])
    if not stamps:
        raise InputError.at(path, "lists no entries")
    return _Listing(np.array(stamps), values)


def _accelerations(path: Path) -> np.ndarray:
    """``(N, 4)`` rows ``timestamp ax ay az`` (m/s^2) from accelerometer.txt."""
    listing = _read_listing(path, value_fields=3)
    try:
        values = np.array(listing.values, dtype=np.float64)
    except ValueError:
        raise InputError.at(path, "an acceleration is not a number") from None
    return np.column_stack([listing.stamps, values])
