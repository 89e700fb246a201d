"""Write a generated run as a TUM RGB-D folder (plus camera.json and scenario.json)."""

import json
from pathlib import Path

import cv2
import numpy as np

from ...geometry.camera import Camera
from ...geometry.trajectory import Trajectory, format_tum

# Colour is stored without compression: deflate finds little in sensor noise (files shrink
# by 1.7x) and zlib's Huffman coding alone would take a quarter of a frame's time. Depth
# (large smooth areas, zeros) shrinks 3x with the "sub" filter alone (libpng's adaptive
# choice tries all five on every row) and Huffman coding without string matching.
# At 640x480: colour 900 KB, depth about 200 KB.
COLOUR_PNG = [cv2.IMWRITE_PNG_COMPRESSION, 0, cv2.IMWRITE_PNG_FILTER, cv2.IMWRITE_PNG_FILTER_NONE]
DEPTH_PNG = [
    cv2.IMWRITE_PNG_COMPRESSION,
    1,
    cv2.IMWRITE_PNG_STRATEGY,
    cv2.IMWRITE_PNG_STRATEGY_HUFFMAN_ONLY,
    cv2.IMWRITE_PNG_FILTER,
    cv2.IMWRITE_PNG_FILTER_SUB,
]


def image_name(kind: str, stamp: float) -> str:
    return f"{kind}/{stamp:.6f}.png"


def prepare(folder: Path) -> None:
    (folder / "rgb").mkdir(parents=True, exist_ok=True)
    (folder / "depth").mkdir(parents=True, exist_ok=True)


def encode_frame(rgb: np.ndarray, depth: np.ndarray, depth_factor: float) -> tuple[bytes, bytes]:
    """PNG files of one RGB image (RGB order in memory) and one depth image (metres, stored as uint16)."""
    stored = np.clip(np.rint(depth * depth_factor), 0, np.iinfo(np.uint16).max).astype(np.uint16)
    return _png(cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), COLOUR_PNG), _png(stored, DEPTH_PNG)


def _png(image: np.ndarray, options: list[int]) -> bytes:
    ok, encoded = cv2.imencode(".png", image, options)
    if not ok:
        raise RuntimeError("PNG encoding failed")
    return encoded.tobytes()


def write_frame(folder: Path, colour_stamp: float, rgb_png: bytes, depth_stamp: float, depth_png: bytes) -> None:
    """The encoded colour and depth images of one frame, named by their stamps."""
    (folder / image_name("rgb", colour_stamp)).write_bytes(rgb_png)
    (folder / image_name("depth", depth_stamp)).write_bytes(depth_png)


def _listing(title: str, source: str, kind: str, stamps: np.ndarray) -> str:
    header = f"# {title}\n# file: '{source}'\n# timestamp filename\n"
    return header + "".join(f"{stamp:.6f} {image_name(kind, stamp)}\n" for stamp in stamps)


def write_index(
    folder: Path,
    source: str,
    colour_stamps: np.ndarray,
    depth_stamps: np.ndarray,
    groundtruth: Trajectory,
    camera: Camera,
    info: dict,
) -> None:
    """rgb.txt, depth.txt and groundtruth.txt with TUM's three header lines; camera.json; scenario.json."""
    (folder / "rgb.txt").write_text(_listing("color images", source, "rgb", colour_stamps))
    (folder / "depth.txt").write_text(_listing("depth maps", source, "depth", depth_stamps))
    (folder / "groundtruth.txt").write_text(
        f"# ground truth trajectory\n# file: '{source}'\n# timestamp tx ty tz qx qy qz qw\n" + format_tum(groundtruth)
    )
    camera.save(folder / "camera.json")
    (folder / "scenario.json").write_text(json.dumps(info, indent=2) + "\n")
