"""Bad input to every command: exit code 2, one line on stderr naming the file or option, no
traceback, and the outputs of an earlier run left exactly as they were.

Almost every case fails before the first frame; the few that fail on the first frame read a
three-frame excerpt of the shared fr1/rpy sequence.
"""

import json
import os
import shutil
import struct
import subprocess
import sys
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest
from fixtures_eval import TUM_RPY, tum_excerpt

from viewer_slam.cli import main

pytestmark = pytest.mark.skipif(not TUM_RPY.is_dir(), reason="shared TUM excerpt not present")

EARLIER = {
    "run.rrd": b"earlier recording",
    "run.json": b'{"earlier": true}\n',
    "run.rgbdslam.txt": b"# earlier rgbdslam\n",
    "run.rtabmap.txt": b"# earlier rtabmap\n",
}


@dataclass
class Case:
    """``arguments`` may use {seq}, {out} and {tmp}; ``prepare`` alters the sequence copy first."""

    arguments: list[str]
    names: str
    prepare: Callable[[Path, Path], None] | None = None


def write(relative: str, content: bytes | str) -> Callable[[Path, Path], None]:
    def prepare(seq: Path, tmp: Path) -> None:
        path = tmp / relative.removeprefix("tmp/") if relative.startswith("tmp/") else seq / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(content.encode() if isinstance(content, str) else content)

    return prepare


def mkdir(relative: str) -> Callable[[Path, Path], None]:
    def prepare(seq: Path, tmp: Path) -> None:
        (tmp / relative).mkdir(parents=True)

    return prepare


def first_image(seq: Path, folder: str) -> Path:
    return sorted((seq / folder).iterdir())[0]


def corrupt_image_data(seq: Path, tmp: Path) -> None:
    """Zeroes in the middle of the first colour image's compressed data (its chunks' lengths kept)."""
    image = first_image(seq, "rgb")
    data = bytearray(image.read_bytes())
    data[len(data) // 2 : len(data) // 2 + 64] = bytes(64)
    image.write_bytes(bytes(data))


def invalid_compressed_data(seq: Path, tmp: Path) -> None:
    """The first colour image's IDAT data damaged with its CRC recomputed: every chunk checks
    out, only the zlib stream inside is invalid (where libpng would print its own line)."""
    image = first_image(seq, "rgb")
    data = bytearray(image.read_bytes())
    offset = 8
    while data[offset + 4 : offset + 8] != b"IDAT":
        offset += 12 + struct.unpack(">I", data[offset : offset + 4])[0]
    (length,) = struct.unpack(">I", data[offset : offset + 4])
    start = offset + 8 + length // 2
    data[start : start + 64] = bytes(64)
    data[offset + 8 + length : offset + 12 + length] = struct.pack(
        ">I", zlib.crc32(data[offset + 4 : offset + 8 + length])
    )
    image.write_bytes(bytes(data))


def truncate_image(seq: Path, tmp: Path) -> None:
    image = first_image(seq, "rgb")
    image.write_bytes(image.read_bytes()[:5000])


def remove_image(seq: Path, tmp: Path) -> None:
    first_image(seq, "depth").unlink()


def eight_bit_depth(seq: Path, tmp: Path) -> None:
    import cv2
    import numpy as np

    cv2.imwrite(str(first_image(seq, "depth")), np.zeros((480, 640), np.uint8))


def shift_depth_stamps(seq: Path, tmp: Path) -> None:
    lines = (seq / "depth.txt").read_text().splitlines()
    (seq / "depth.txt").write_text(
        "\n".join(
            f"{float(line.split()[0]) + 100:.6f} {line.split()[1]}" if not line.startswith("#") else line
            for line in lines
        )
        + "\n"
    )


def replace_line(listing: str, text: str) -> Callable[[Path, Path], None]:
    def prepare(seq: Path, tmp: Path) -> None:
        lines = (seq / listing).read_text().splitlines()
        index = next(i for i, line in enumerate(lines) if not line.startswith("#"))
        lines[index] = text
        (seq / listing).write_text("\n".join(lines) + "\n")

    return prepare


CAMERA = {"fx": 517.3, "fy": 516.5, "cx": 318.6, "cy": 255.3, "width": 640, "height": 480}


def camera(**changes) -> Callable[[Path, Path], None]:
    return write("camera.json", json.dumps(CAMERA | changes).replace("Infinity", "1e999"))


def copy(relative: str, target: str) -> Callable[[Path, Path], None]:
    """Copy the sequence's file ``relative`` to ``tmp/target``."""

    def prepare(seq: Path, tmp: Path) -> None:
        shutil.copyfile(seq / relative, tmp / target)

    return prepare


def hard_link(relative: str, target: str) -> Callable[[Path, Path], None]:
    """The sequence's file ``relative`` also under the name ``tmp/target`` (the same inode)."""

    def prepare(seq: Path, tmp: Path) -> None:
        os.link(seq / relative, tmp / target)

    return prepare


def png_header(width: int, height: int) -> bytes:
    """A PNG whose chunks are all valid, announcing ``width`` x ``height`` RGB pixels, with one
    tiny IDAT: a decoder would have to allocate the whole image before finding the data short."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
        + chunk(b"IDAT", zlib.compress(b"\0" * 16))
        + chunk(b"IEND", b"")
    )


def replace_image(folder: str, content: bytes) -> Callable[[Path, Path], None]:
    def prepare(seq: Path, tmp: Path) -> None:
        first_image(seq, folder).write_bytes(content)

    return prepare


def estimate(lines: str) -> Callable[[Path, Path], None]:
    """``tmp/e.txt``: the first groundtruth stamps of the excerpt with poses from ``lines``
    (each ``tx ty tz qx qy qz qw``, used in turn)."""

    def prepare(seq: Path, tmp: Path) -> None:
        stamps = [line.split()[0] for line in (seq / "rgb.txt").read_text().splitlines() if not line.startswith("#")]
        poses = lines.splitlines()
        (tmp / "e.txt").write_text("".join(f"{stamp} {poses[i % len(poses)]}\n" for i, stamp in enumerate(stamps)))

    return prepare


def nested(depth: int, leaf: str = "1") -> str:
    """A JSON array (TOML too) nested ``depth`` levels deep."""
    return "[" * depth + leaf + "]" * depth


def jpeg(mutate: Callable[[bytearray], None]) -> Callable[[Path, Path], None]:
    """The first colour image as a JPEG, damaged by ``mutate`` (its bytes, changed in place)."""

    def prepare(seq: Path, tmp: Path) -> None:
        import cv2

        data = bytearray(cv2.imencode(".jpg", cv2.imread(str(first_image(seq, "rgb"))))[1].tobytes())
        mutate(data)
        first_image(seq, "rgb").write_bytes(bytes(data))

    return prepare


def tiny_bag(
    name: str, damage: Callable[[bytearray], None] | None = None, frames: int = 4, depth: float = 1.5
) -> Callable[[Path, Path], None]:
    """``tmp/name``: a ROS 1 bag of 32x24 frames whose depth is ``depth`` m everywhere, then ``damage``d."""

    def prepare(seq: Path, tmp: Path) -> None:
        import numpy as np
        from bag_writer import BagWriter

        rng = np.random.default_rng(0)
        with BagWriter(tmp / name, 1) as bag:
            for k in range(frames):
                stamp = 5 * 10**9 + k * 33_333_333
                bag.image("/cam/rgb", stamp, "cam", rng.integers(0, 256, (24, 32, 3), dtype=np.uint8), "bgr8")
                bag.camera_info("/cam/camera_info", stamp, "cam", 32, 24, (40.0, 41.0, 15.5, 11.5), (0, 0, 0, 0, 0))
                bag.image("/cam/depth", stamp + 1000, "cam", np.full((24, 32), depth, np.float32), "32FC1")
        if damage is not None:
            data = bytearray((tmp / name).read_bytes())
            damage(data)
            (tmp / name).write_bytes(bytes(data))

    return prepare


def flip_depth_exponent(data: bytearray) -> None:
    """Flip bits of one depth value's exponent inside the bag's chunk: 1.5 m becomes 1.3e38 m."""
    offset = data.index(struct.pack("<f", 1.5) * 8)
    data[offset + 3] ^= 0x41


def damage_record_header(data: bytearray) -> None:
    """A field length in the header of the first message record inside the first chunk made huge."""
    offset = data.index(b"op=\x02", data.index(b"op=\x05"))
    data[offset - 4 : offset] = b"\xff\xff\x00\x00"


def damage_record_kind(data: bytearray) -> None:
    """The first message record inside the first chunk made a record of no known kind."""
    offset = data.index(b"op=\x02", data.index(b"op=\x05"))
    data[offset + 3] = 0x09


def truncate_chunk(data: bytearray) -> None:
    del data[len(data) * 2 // 3 :]


def report(**changes) -> str:
    """A `viewslam record` report of one run, as far as `diff` reads it before the trajectories."""
    block = {
        "frames_with_pose": 2,
        "ate": None,
        "rpe": None,
        "coverage": None,
        "penalized_ate": None,
        "tracking_lost": [],
        "parameters": {},
    }
    data = {"sequence": {"name": "s", "path": "/nowhere", "frames": 3}, "pipelines": {"run": block}}
    for key, value in changes.items():
        where, _, name = key.rpartition("__")
        target = {"sequence": data["sequence"], "run": block, "": data}[where]
        target[name] = value
    return json.dumps(data)


DIFF = ["diff", "{tmp}/a.json", "{tmp}/a.json"]


RECORD = ["record", "{seq}", "--out", "{out}", "--quiet"]
RGBDSLAM = [*RECORD, "--pipeline", "rgbdslam"]

RECORD_CASES = {
    # options
    "pipeline-unknown": Case([*RECORD, "--pipeline", "orbslam"], "--pipeline 'orbslam'"),
    "pipeline-empty": Case([*RECORD, "--pipeline", ","], "--pipeline ','"),
    "pipeline-list-one-unknown": Case([*RECORD, "--pipeline", "both,orb"], "--pipeline 'both,orb'"),
    "max-keypoints-negative": Case([*RECORD, "--param", "max_keypoints=-5"], "max_keypoints"),
    "predecessors-zero": Case([*RECORD, "--param", "predecessor_candidates=0"], "predecessor_candidates"),
    "stm-size-negative": Case([*RECORD, "--param", "Mem/STMSize=-3"], "Mem/STMSize"),
    "predecessors-inf": Case([*RECORD, "--param", "predecessor_candidates=inf"], "predecessor_candidates"),
    "predecessors-1e400": Case([*RECORD, "--param", "predecessor_candidates=1e400"], "predecessor_candidates"),
    "predecessors-huge": Case([*RECORD, "--param", "predecessor_candidates=99999999999"], "predecessor_candidates"),
    "grid-zero": Case([*RECORD, "--param", "detector_grid_resolution=0"], "detector_grid_resolution"),
    "ratio-nan": Case([*RECORD, "--param", "nn_distance_ratio=nan"], "nn_distance_ratio"),
    "ratio-1e400": Case([*RECORD, "--param", "nn_distance_ratio=1e400"], "nn_distance_ratio"),
    "ratio-above-one": Case([*RECORD, "--param", "nn_distance_ratio=1.5"], "nn_distance_ratio"),
    "ratio-text": Case([*RECORD, "--param", "nn_distance_ratio=high"], "nn_distance_ratio"),
    "integer-fraction": Case([*RECORD, "--param", "max_keypoints=2.5"], "max_keypoints"),
    "depth-range-inverted": Case(
        [*RECORD, "--param", "minimum_depth=2", "--param", "maximum_depth=1"],
        "maximum_depth must be above minimum_depth (2.0), or 0 for no limit, got 1.0",
    ),
    "vis-depth-range-inverted": Case(
        [*RECORD, "--param", "Vis/MinDepth=3", "--param", "Vis/MaxDepth=0.5"],
        "Vis/MaxDepth must be above Vis/MinDepth (3.0)",
    ),
    "matches-cap-below-minimum": Case(
        [*RECORD, "--param", "max_matches=10"], "max_matches must be at least min_matches (20), got 10"
    ),
    "config-and-param-inverted": Case(
        [*RECORD, "--config", "{tmp}/c.toml", "--param", "minimum_depth=2"],
        "c.toml and --param: parameter maximum_depth",
        write("tmp/c.toml", "[rgbdslam]\nmaximum_depth = 1.5\n"),
    ),
    "detector-surf": Case([*RECORD, "--param", "feature_detector_type=SURF"], "SURF"),
    "detector-unknown": Case([*RECORD, "--param", "feature_detector_type=FAST"], "feature_detector_type"),
    "boolean-maybe": Case([*RECORD, "--param", "RGBD/ProximityBySpace=maybe"], "RGBD/ProximityBySpace"),
    "param-unknown": Case([*RECORD, "--param", "nonsense=1"], "'nonsense'"),
    "param-no-equals": Case([*RECORD, "--param", "max_keypoints"], "--param 'max_keypoints'"),
    "param-no-key": Case([*RECORD, "--param", "=5"], "--param '=5'"),
    "seed-negative": Case([*RECORD, "--seed", "-1"], "--seed"),
    "seed-too-large": Case([*RECORD, "--seed", "99999999999"], "--seed"),
    "seed-text": Case([*RECORD, "--seed", "one"], "--seed"),
    "max-frames-zero": Case([*RECORD, "--max-frames", "0"], "--max-frames"),
    "stride-zero": Case([*RECORD, "--stride", "0"], "--stride"),
    "unknown-option": Case([*RECORD, "--frames", "3"], "--frames"),
    # --config
    "config-missing": Case([*RECORD, "--config", "{tmp}/nope.toml"], "nope.toml"),
    "config-undecodable": Case([*RECORD, "--config", "{tmp}/c.toml"], "c.toml", write("tmp/c.toml", b"\xff\xfe = 1\n")),
    "config-misspelt-table": Case(
        [*RECORD, "--config", "{tmp}/c.toml"], "[rgbd_slam]", write("tmp/c.toml", "[rgbd_slam]\nmax_keypoints = 100\n")
    ),
    "config-broken": Case(
        [*RECORD, "--config", "{tmp}/c.toml"], "c.toml", write("tmp/c.toml", "max_keypoints = = 1\n")
    ),
    "config-folder": Case([*RECORD, "--config", "{tmp}/c.toml"], "c.toml", mkdir("c.toml")),
    "config-wrong-type": Case(
        [*RECORD, "--config", "{tmp}/c.toml"], "max_keypoints", write("tmp/c.toml", 'max_keypoints = "many"\n')
    ),
    "config-table-out-of-range": Case(
        [*RECORD, "--config", "{tmp}/c.toml"], "max_keypoints", write("tmp/c.toml", "[rgbdslam]\nmax_keypoints = -1\n")
    ),
    "config-bool-for-float": Case(
        [*RECORD, "--config", "{tmp}/c.toml"],
        "nn_distance_ratio expects a number",
        write("tmp/c.toml", "nn_distance_ratio = true\n"),
    ),
    "config-bool-for-int": Case(
        [*RECORD, "--config", "{tmp}/c.toml"],
        "max_keypoints expects an integer",
        write("tmp/c.toml", "[rgbdslam]\nmax_keypoints = false\n"),
    ),
    "config-text-for-int": Case(
        [*RECORD, "--config", "{tmp}/c.toml"],
        "Vis/MaxFeatures expects an integer",
        write("tmp/c.toml", '[rtabmap]\n"Vis/MaxFeatures" = "500"\n'),
    ),
    "config-fraction-for-int": Case(
        [*RECORD, "--config", "{tmp}/c.toml"],
        "Mem/STMSize expects an integer",
        write("tmp/c.toml", '"Mem/STMSize" = 10.0\n'),
    ),
    "pipeline-empty-string": Case([*RECORD, "--pipeline", ""], "--pipeline ''"),
    "config-table-unknown-key": Case(
        [*RECORD, "--config", "{tmp}/c.toml"], "'Mem/STMSize'", write("tmp/c.toml", '[rgbdslam]\n"Mem/STMSize" = 3\n')
    ),
    # outputs
    "out-not-rrd": Case([*RECORD[:3], "{tmp}/out/run.txt", "--quiet"], "run.txt"),
    "out-is-folder": Case([*RECORD[:3], "{tmp}/out/dir.rrd", "--quiet"], "dir.rrd", mkdir("out/dir.rrd")),
    "out-under-a-file": Case([*RECORD[:3], "{seq}/rgb.txt/x.rrd", "--quiet"], "rgb.txt/x.rrd"),
    "report-is-folder": Case([*RECORD[:3], "{tmp}/out/other.rrd", "--quiet"], "other.json", mkdir("out/other.json")),
    "trajectory-is-folder": Case(
        [*RECORD[:3], "{tmp}/out/other.rrd", "--quiet"], "other.rtabmap.txt", mkdir("out/other.rtabmap.txt")
    ),
    "out-name-too-long": Case([*RECORD[:3], "{tmp}/out/" + "n" * 300 + ".rrd", "--quiet"], "n" * 300),
    "out-name-not-utf8": Case([*RECORD[:3], "{tmp}/out/run\udcff.rrd", "--quiet"], "run\\xff.rrd"),
    "out-under-a-file-deeper": Case([*RECORD[:3], "{seq}/rgb.txt/a/b/x.rrd", "--quiet"], "rgb.txt"),
    # inputs are never outputs
    "trajectory-is-the-estimate": Case(
        [*RECORD, "--estimate", "mine={tmp}/out/run.mine.txt"],
        "run.mine.txt",
        copy("groundtruth.txt", "out/run.mine.txt"),
    ),
    "trajectory-is-the-estimate-by-inode": Case(
        [*RECORD, "--estimate", "mine={seq}/groundtruth.txt"],
        "run.mine.txt",
        hard_link("groundtruth.txt", "out/run.mine.txt"),
    ),
    "report-is-the-config": Case(
        [*RECORD, "--config", "{tmp}/out/run.json"], "run.json", write("tmp/out/run.json", "max_keypoints = 100\n")
    ),
    # the sequence
    "estimate-missing": Case([*RECORD, "--estimate", "mine={tmp}/nope.txt"], "nope.txt"),
    "estimate-unknown-format": Case(
        [*RECORD, "--estimate", "mine={tmp}/e.txt"], "e.txt", write("tmp/e.txt", "poses follow\n")
    ),
    "estimate-folder": Case([*RECORD, "--estimate", "mine={tmp}/e.txt"], "e.txt", mkdir("e.txt")),
    "estimate-no-equals": Case([*RECORD, "--estimate", "{tmp}/e.txt"], "--estimate '"),
    "estimate-clashes-pipeline": Case(
        [*RECORD, "--pipeline", "rgbdslam", "--estimate", "rgbdslam={tmp}/e.txt"], "--estimate rgbdslam="
    ),
    "estimate-clashes-estimate": Case(
        [*RECORD, "--estimate", "a={tmp}/e.txt", "--estimate", "a={tmp}/f.txt"], "--estimate a="
    ),
    "estimate-name-with-slash": Case([*RECORD, "--estimate", "orb/3={tmp}/e.txt"], "--estimate orb/3="),
    "estimate-format-unknown": Case([*RECORD, "--estimate", "a={tmp}/e.txt", "--format", "g2o"], "'g2o' is not one of"),
    "bag-option-on-folder": Case([*RECORD, "--rgb-topic", "/camera/rgb"], "--rgb-topic"),
    "sequence-missing": Case(["record", "{tmp}/nothing", "--out", "{out}"], "nothing"),
    "sequence-is-file": Case(["record", "{seq}/rgb.txt", "--out", "{out}"], "rgb.txt"),
    "sequence-unknown-name": Case(["record", "fr9/nothing", "--out", "{out}"], "fr9/nothing"),
    "sequence-not-downloaded": Case(["record", "fr1/xyz", "--out", "{out}"], "fr1/xyz"),
    "no-rgb-listing": Case(RECORD, "rgb.txt", lambda seq, tmp: (seq / "rgb.txt").unlink()),
    "listing-three-fields": Case(RECORD, "rgb.txt:4", replace_line("rgb.txt", "1.0 rgb/a.png extra")),
    "listing-bad-stamp": Case(RECORD, "rgb.txt:4", replace_line("rgb.txt", "soon rgb/a.png")),
    "listing-nan-stamp": Case(RECORD, "rgb.txt:4", replace_line("rgb.txt", "nan rgb/a.png")),
    "listing-empty": Case(RECORD, "depth.txt", write("depth.txt", "# nothing\n")),
    "listing-undecodable": Case(RECORD, "rgb.txt", write("rgb.txt", b"\xff\xfe1.0 rgb/a.png\n")),
    "no-association": Case(RECORD, "depth.txt", shift_depth_stamps),
    "groundtruth-bad-line": Case(RECORD, "groundtruth.txt", write("groundtruth.txt", "1.0 2.0 3.0\n")),
    "accelerometer-bad": Case(RECORD, "accelerometer.txt", write("accelerometer.txt", "1.0 x y z\n")),
    "camera-null": Case(RECORD, "camera.json", write("camera.json", "null")),
    "camera-number": Case(RECORD, "camera.json", write("camera.json", "42")),
    "camera-list": Case(RECORD, "camera.json", write("camera.json", "[1, 2]")),
    "camera-not-json": Case(RECORD, "camera.json", write("camera.json", "{fx: 1")),
    "camera-fx-zero": Case(RECORD, "camera.json", camera(fx=0)),
    "camera-fx-nan": Case(RECORD, "camera.json", write("camera.json", json.dumps(CAMERA).replace("517.3", "NaN"))),
    "camera-fx-infinite": Case(RECORD, "camera.json", camera(fx=float("inf"))),
    "camera-fy-negative": Case(RECORD, "camera.json", camera(fy=-500)),
    "camera-depth-factor-zero": Case(RECORD, "camera.json", camera(depth_factor=0)),
    "camera-width-zero": Case(RECORD, "camera.json", camera(width=0)),
    "camera-width-text": Case(RECORD, "camera.json", camera(width="wide")),
    "camera-missing-key": Case(
        RECORD, "camera.json", write("camera.json", json.dumps({k: v for k, v in CAMERA.items() if k != "cy"}))
    ),
    "camera-cx-huge": Case(RECORD, "camera.json", camera(cx=1e308)),
    "camera-fx-huge": Case(RECORD, "camera.json", camera(fx=1e300)),
    "camera-depth-factor-tiny": Case(RECORD, "camera.json", camera(depth_factor=1e-300)),
    "camera-one-pixel": Case(RECORD, "camera.json", camera(width=1, height=1)),
    "camera-huge": Case(RECORD, "camera.json", camera(width=100_000, height=100_000)),
    "camera-distortion-huge": Case(RECORD, "camera.json", camera(distortion=[1e300, 0, 0, 0, 0])),
    "camera-distortion-text": Case(RECORD, "camera.json", camera(distortion=[0, "a", 0, 0, 0])),
    # the first frame
    "camera-size-differs": Case(RGBDSLAM, "rgb/", camera(width=320, height=240, cx=160, cy=120)),
    "png-corrupt-data": Case(RGBDSLAM, "rgb/", corrupt_image_data),
    "png-invalid-compressed-data": Case(RGBDSLAM, "rgb/", invalid_compressed_data),
    "png-truncated": Case(RGBDSLAM, "rgb/", truncate_image),
    "png-not-an-image": Case(RGBDSLAM, "rgb/", lambda seq, tmp: first_image(seq, "rgb").write_bytes(b"hello")),
    "png-huge-header": Case(RGBDSLAM, "rgb/", replace_image("rgb", png_header(20000, 20000))),
    "png-one-pixel": Case(RGBDSLAM, "depth/", replace_image("depth", png_header(1, 1))),
    "image-missing": Case(RGBDSLAM, "depth/", remove_image),
    "depth-eight-bit": Case(RGBDSLAM, "depth/", eight_bit_depth),
    # deeply nested, oversized and mistyped structured files
    "camera-nested-deep": Case(
        RECORD, "camera.json: cannot read camera calibration: nested more than", write("camera.json", nested(100_000))
    ),
    "camera-nested-inside-a-value": Case(
        RECORD,
        "camera.json: cannot read camera calibration: nested more than",
        camera(distortion=json.loads(nested(40, "0"))),
    ),
    "camera-too-large": Case(
        RECORD,
        "camera.json: cannot read camera calibration: 2,",
        write("camera.json", json.dumps(CAMERA) + " " * 2_000_000),
    ),
    "camera-integer-too-long": Case(
        RECORD,
        "camera.json: cannot read camera calibration: not valid JSON",
        write("camera.json", json.dumps(CAMERA).replace("640", "6" * 5000)),
    ),
    "config-nested-arrays": Case(
        [*RECORD, "--config", "{tmp}/c.toml"],
        "c.toml: cannot read config: nested more than",
        write("tmp/c.toml", f"max_keypoints = {nested(5000)}\n"),
    ),
    "config-nested-tables": Case(
        [*RECORD, "--config", "{tmp}/c.toml"],
        "c.toml: cannot read config: nested more than",
        write("tmp/c.toml", "max_keypoints = " + "{a = " * 3000 + "1" + "}" * 3000 + "\n"),
    ),
    "config-integer-too-long": Case(
        [*RECORD, "--config", "{tmp}/c.toml"],
        "c.toml: cannot read config: not valid TOML",
        write("tmp/c.toml", "max_keypoints = " + "1" * 5000 + "\n"),
    ),
    # images whose damage libjpeg would print about
    "jpeg-bad-marker": Case(RGBDSLAM, "rgb/", jpeg(lambda data: data.__setitem__(slice(2, 4), b"\xff\x01"))),
    "jpeg-truncated": Case(RGBDSLAM, "rgb/", jpeg(lambda data: data.__delitem__(slice(len(data) // 2, None)))),
    "jpeg-end-in-the-header": Case(RGBDSLAM, "rgb/", jpeg(lambda data: data.__setitem__(slice(20, 22), b"\xff\xd9"))),
    # damaged ROS 1 bags
    "bag-depth-bits-flipped": Case(
        ["record", "{tmp}/b.bag", "--out", "{out}", "--quiet", "--pipeline", "rtabmap"],
        "b.bag: frame 0 (5.000000 s): /cam/depth: depth 1.27606e+38 m at pixel (0, 0)",
        tiny_bag("b.bag", flip_depth_exponent),
    ),
    "bag-record-header-damaged": Case(
        ["record", "{tmp}/b.bag", "--out", "{out}", "--quiet"],
        "b.bag: cannot read the bag: Declared field size is too large",
        tiny_bag("b.bag", damage_record_header),
    ),
    "bag-record-kind-damaged": Case(
        ["record", "{tmp}/b.bag", "--out", "{out}", "--quiet"],
        "b.bag: cannot read the bag: Expected to find message data",
        tiny_bag("b.bag", damage_record_kind),
    ),
    "bag-chunk-truncated": Case(
        ["record", "{tmp}/b.bag", "--out", "{out}", "--quiet"], "b.bag: ", tiny_bag("b.bag", truncate_chunk)
    ),
}

BENCHMARK = ["benchmark", "{seq}", "--out", "{tmp}/bench", "--quiet", "--no-cache"]
BENCHMARK_CASES = {
    "benchmark-out-is-file": Case(["benchmark", "{seq}", "--out", "{seq}/rgb.txt"], "rgb.txt: is a file"),
    "benchmark-pipeline-unknown": Case([*BENCHMARK, "--pipeline", "orb"], "--pipeline 'orb'"),
    "benchmark-old-pipelines-unknown": Case([*BENCHMARK, "--pipelines", "orb"], "--pipeline 'orb'"),
    "benchmark-resolution": Case([*BENCHMARK, "--resolution", "64by48"], "--resolution '64by48'"),
    "benchmark-resolution-huge": Case([*BENCHMARK, "--resolution", "99999x10"], "--resolution '99999x10'"),
    "benchmark-executor": Case([*BENCHMARK, "--executor", "slurm"], "--executor 'slurm'"),
    "benchmark-ray-address": Case([*BENCHMARK, "--ray-address", "auto"], "--ray-address"),
    "benchmark-param": Case([*BENCHMARK, "--param", "max_keypoints=-5"], "max_keypoints"),
    "benchmark-param-inf": Case([*BENCHMARK, "--param", "predecessor_candidates=inf"], "predecessor_candidates"),
    "benchmark-seed-negative": Case([*BENCHMARK, "--seed", "-1"], "--seed"),
    "benchmark-max-frames-one": Case([*BENCHMARK, "--max-frames", "1"], "--max-frames"),
    "benchmark-jobs-zero": Case([*BENCHMARK, "--jobs", "0"], "--jobs"),
    "benchmark-timeout-inf": Case([*BENCHMARK, "--timeout", "inf"], "--timeout"),
    "benchmark-timeout-nan": Case([*BENCHMARK, "--timeout", "nan"], "--timeout"),
    "benchmark-timeout-zero": Case([*BENCHMARK, "--timeout", "0"], "--timeout"),
    "benchmark-config-undecodable": Case(
        [*BENCHMARK, "--config", "{tmp}/c.toml"], "c.toml", write("tmp/c.toml", b"\xff\xfe\n")
    ),
    "benchmark-config-misspelt-table": Case(
        [*BENCHMARK, "--config", "{tmp}/c.toml"], "[rtab_map]", write("tmp/c.toml", "[rtab_map]\n")
    ),
    "benchmark-old-frames-option": Case([*BENCHMARK, "--frames", "60"], "--frames"),
    "benchmark-estimate-is-a-run-trajectory": Case(
        [*BENCHMARK, "--estimate", "mine={tmp}/bench/runs/rgbd_dataset_freiburg1_rpy.mine.txt"],
        "runs/rgbd_dataset_freiburg1_rpy.mine.txt is the input --estimate mine=",
        lambda seq, tmp: (
            (tmp / "bench/runs").mkdir(parents=True)
            or copy("groundtruth.txt", "bench/runs/rgbd_dataset_freiburg1_rpy.mine.txt")(seq, tmp)
        ),
    ),
    "benchmark-config-is-the-results": Case(
        [*BENCHMARK, "--config", "{tmp}/bench/results.json"],
        "results.json is the input --config",
        write("tmp/bench/results.json", ""),
    ),
    "benchmark-unknown-sequence": Case(["benchmark", "fr9/none", "--out", "{tmp}/bench", "--quiet"], "fr9/none"),
}

OTHER_CASES = {
    "download-unknown": Case(["download", "fr9/none", "--dest", "{tmp}/d"], "fr9/none"),
    "download-mirror-not-url": Case(
        ["download", "fr1/xyz", "--dest", "{tmp}/d", "--mirror", "notaurl"], "--mirror 'notaurl'"
    ),
    "download-mirror-ftp": Case(
        ["download", "fr1/xyz", "--dest", "{tmp}/d", "--mirror", "ftp://host/x"], "--mirror 'ftp://host/x'"
    ),
    "download-mirror-bad-ipv6": Case(
        ["download", "fr1/xyz", "--dest", "{tmp}/d", "--mirror", "http://[::1/x"], "--mirror 'http://[::1/x'"
    ),
    "download-mirror-bad-port": Case(
        ["download", "fr1/xyz", "--dest", "{tmp}/d", "--mirror", "http://host:port/x"], "--mirror 'http://host:port/x'"
    ),
    "sequence-name-with-newline": Case(["record", "{tmp}/no\nsuch", "--out", "{out}"], "no\\nsuch"),
    "evaluate-estimate-name-with-newline": Case(["evaluate", "{seq}/groundtruth.txt", "{tmp}/e\n.txt"], "e\\n.txt"),
    "download-dest-is-file": Case(
        ["download", "fr1/xyz", "--dest", "{seq}/rgb.txt", "--mirror", "http://localhost:9"], "rgb.txt"
    ),
    "evaluate-groundtruth-missing": Case(["evaluate", "{tmp}/none.txt", "{seq}/groundtruth.txt"], "none.txt"),
    "evaluate-estimate-bad-line": Case(
        ["evaluate", "{seq}/groundtruth.txt", "{tmp}/e.txt"], "e.txt", write("tmp/e.txt", "1.0 2.0\n")
    ),
    "evaluate-no-overlap": Case(
        ["evaluate", "{seq}/groundtruth.txt", "{tmp}/e.txt"],
        "e.txt",
        write("tmp/e.txt", "1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 0 1\n"),
    ),
    "evaluate-json-is-the-estimate": Case(
        ["evaluate", "{seq}/groundtruth.txt", "{tmp}/out/e.txt", "--json", "{tmp}/out/e.txt"],
        "--json",
        copy("groundtruth.txt", "out/e.txt"),
    ),
    "evaluate-json-is-the-groundtruth": Case(
        ["evaluate", "{tmp}/out/gt.txt", "{seq}/groundtruth.txt", "--json", "{tmp}/out/gt.txt"],
        "--json",
        copy("groundtruth.txt", "out/gt.txt"),
    ),
    "evaluate-plot-is-the-estimate": Case(
        ["evaluate", "{seq}/groundtruth.txt", "{tmp}/out/e.txt", "--plot", "{tmp}/out/e.txt"],
        "--plot",
        copy("groundtruth.txt", "out/e.txt"),
    ),
    "evaluate-json-is-the-estimate-by-inode": Case(
        ["evaluate", "{seq}/groundtruth.txt", "{seq}/groundtruth.txt", "--json", "{tmp}/out/e.json"],
        "--json",
        hard_link("groundtruth.txt", "out/e.json"),
    ),
    "evaluate-json-is-the-plot": Case(
        [
            "evaluate",
            "{seq}/groundtruth.txt",
            "{seq}/groundtruth.txt",
            "--json",
            "{tmp}/out/e.json",
            "--plot",
            "{tmp}/out/e.json",
        ],
        "--plot",
    ),
    "evaluate-delta-huge": Case(
        ["evaluate", "{seq}/groundtruth.txt", "{seq}/groundtruth.txt", "--delta", "1e300", "--delta-unit", "frames"],
        "--delta",
    ),
    "evaluate-delta-inf": Case(
        ["evaluate", "{seq}/groundtruth.txt", "{seq}/groundtruth.txt", "--delta", "inf"], "--delta"
    ),
    "evaluate-estimate-nan": Case(
        ["evaluate", "{seq}/groundtruth.txt", "{tmp}/e.txt"], "e.txt:1", estimate("nan 0 0 0 0 0 1")
    ),
    "evaluate-estimate-huge": Case(
        ["evaluate", "{seq}/groundtruth.txt", "{tmp}/e.txt"],
        "e.txt:2",
        estimate("0 0 0 0 0 0 1\n1e300 1e300 0 0 0 0 1"),
    ),
    "evaluate-estimate-zero-quaternion": Case(
        ["evaluate", "{seq}/groundtruth.txt", "{tmp}/e.txt"], "e.txt:1", estimate("0 0 0 0 0 0 0")
    ),
    "evaluate-estimate-name-too-long": Case(
        ["evaluate", "{seq}/groundtruth.txt", "{tmp}/" + "e" * 300 + ".txt"], "e" * 300
    ),
    "evaluate-folder-without-groundtruth": Case(
        ["evaluate", "{seq}", "{tmp}/gt.txt"],
        "groundtruth.txt",
        lambda seq, tmp: (seq / "groundtruth.txt").rename(tmp / "gt.txt"),
    ),
    "synth-unknown-scenario": Case(["synth", "nowhere", "--out", "{tmp}/s"], "nowhere"),
    "synth-resolution": Case(["synth", "360_kidnap", "--out", "{tmp}/s", "--resolution", "0x480"], "--resolution"),
    "synth-frames-zero": Case(["synth", "360_kidnap", "--out", "{tmp}/s", "--frames", "0"], "--frames"),
    "synth-frames-huge": Case(["synth", "360_kidnap", "--out", "{tmp}/s", "--frames", "1000000000000"], "--frames"),
    "synth-out-under-a-file": Case(
        ["synth", "360_kidnap", "--out", "{seq}/rgb.txt/s", "--frames", "2", "--resolution", "32x24"], "rgb.txt"
    ),
    "synth-out-read-only": Case(
        ["synth", "360_kidnap", "--out", "/proc/viewslam-synth", "--frames", "2", "--resolution", "32x24"],
        "/proc/viewslam-synth",
    ),
    "synth-out-name-too-long": Case(
        ["synth", "360_kidnap", "--out", "{tmp}/" + "s" * 300, "--frames", "2", "--resolution", "32x24"], "s" * 300
    ),
    "synth-seed-negative": Case(["synth", "360_kidnap", "--out", "{tmp}/s", "--seed", "-1"], "--seed"),
    "synth-out-not-empty": Case(["synth", "360_kidnap", "--out", "{seq}", "--frames", "2"], "--force"),
    "synth-camera-unknown": Case(["synth", "360_kidnap", "--out", "{tmp}/s", "--camera", "fr9"], "fr9"),
    "view-missing": Case(["view", "{tmp}/none.rrd"], "none.rrd"),
    "view-web-empty": Case(
        ["view", "{tmp}/e.rrd", "--web"], "e.rrd: not a complete Rerun recording", write("tmp/e.rrd", b"")
    ),
    "view-web-garbage": Case(["view", "{tmp}/g.rrd", "--web"], "g.rrd: not a complete", write("tmp/g.rrd", b"garbage")),
    "view-web-json": Case(["view", "{tmp}/out/run.json", "--web"], "run.json: not a complete"),
    "view-truncated": Case(["view", "{tmp}/t.rrd"], "t.rrd: not a complete", write("tmp/t.rrd", b"RRF2\0\0\0\0")),
    # reports given to diff: nested, oversized, mistyped
    "diff-report-nested-deep": Case(
        DIFF, "a.json: cannot read the report: nested more than", write("tmp/a.json", nested(100_000))
    ),
    "diff-report-nested-in-a-block": Case(
        DIFF,
        "a.json: cannot read the report: nested more than",
        write("tmp/a.json", report(run__parameters={"k": json.loads(nested(40))})),
    ),
    "diff-report-not-utf8": Case(DIFF, "a.json: cannot read the report: not UTF-8", write("tmp/a.json", b"{\xff}")),
    "diff-run-name-with-slash": Case(
        DIFF,
        "a.json: run name 'orb/3' is not one viewslam writes",
        write("tmp/a.json", report().replace('"run"', '"orb/3"')),
    ),
    "diff-run-name-dot-dot": Case(
        DIFF, "a.json: run name '..' is not one viewslam writes", write("tmp/a.json", report().replace('"run"', '".."'))
    ),
    "diff-sequence-path-number": Case(
        DIFF, "a.json: sequence block: path is int", write("tmp/a.json", report(sequence__path=5))
    ),
    "diff-sequence-frames-text": Case(
        DIFF, "a.json: sequence block: frames must be a count", write("tmp/a.json", report(sequence__frames="three"))
    ),
    "diff-loss-without-timestamp": Case(
        DIFF,
        "a.json: run 'run': tracking_lost is not a list of losses",
        write("tmp/a.json", report(run__tracking_lost=[{"frame": 1, "reason": "x"}])),
    ),
    "diff-lost-interval-text": Case(
        DIFF,
        "a.json: run 'run': coverage is not an object",
        write("tmp/a.json", report(run__coverage={"lost_intervals": [["a", "b"]]})),
    ),
}

CASES = RECORD_CASES | BENCHMARK_CASES | OTHER_CASES


@pytest.fixture(scope="module")
def excerpt(tmp_path_factory) -> Path:
    return tum_excerpt(tmp_path_factory.mktemp("excerpt") / "rgbd_dataset_freiburg1_rpy", frames=3)


def snapshot(folder: Path) -> dict[str, bytes]:
    return {str(path.relative_to(folder)): path.read_bytes() for path in sorted(folder.rglob("*")) if path.is_file()}


def test_the_suite_covers_at_least_eighty_cases():
    assert len(CASES) >= 80


@pytest.mark.parametrize("case", CASES.values(), ids=CASES.keys())
def test_bad_input_is_one_line_exit_2_and_loses_nothing(case, excerpt, tmp_path, capfd, monkeypatch):
    monkeypatch.chdir(tmp_path)
    seq = shutil.copytree(excerpt, tmp_path / excerpt.name)
    out = tmp_path / "out"
    out.mkdir()
    for name, content in EARLIER.items():
        (out / name).write_bytes(content)
    if case.prepare is not None:
        case.prepare(seq, tmp_path)
    before = snapshot(out)
    arguments = [argument.format(seq=seq, out=out / "run.rrd", tmp=tmp_path) for argument in case.arguments]
    assert main(arguments) == 2
    error = capfd.readouterr().err
    assert error.count("\n") == 1 and error.endswith("\n"), error
    assert "Traceback" not in error and "libpng" not in error
    assert case.names in error
    assert snapshot(out) == before
    assert not [path for path in out.iterdir() if path.name.startswith(".")]  # no temporary or lock file left


# Commands that create the cache before anything else.
CACHE_COMMANDS = [
    ["download", "fr1/xyz", "--mirror", "http://localhost:9", "--quiet"],
    ["record", "sitting_static", "--out", "{tmp}/run.rrd", "--quiet"],
    ["benchmark", "sitting_static", "--out", "{tmp}/bench", "--quiet"],
]


@pytest.mark.parametrize("arguments", CACHE_COMMANDS, ids=["download", "record", "benchmark"])
def test_a_cache_that_is_a_file_is_one_line_naming_the_variable(arguments, tmp_path, monkeypatch, capfd):
    (tmp_path / "cache").write_text("not a folder")
    monkeypatch.setenv("VIEWSLAM_CACHE", str(tmp_path / "cache"))
    monkeypatch.delenv("VIEWSLAM_DATA", raising=False)
    assert main([argument.format(tmp=tmp_path) for argument in arguments]) == 2
    error = capfd.readouterr().err
    assert error.count("\n") == 1 and f"VIEWSLAM_CACHE {tmp_path / 'cache'}: cannot create" in error
    assert (tmp_path / "cache").read_text() == "not a folder"


@pytest.fixture
def read_only_cache(tmp_path):
    """An empty cache folder nobody may write: a read-only tmpfs when root (root ignores modes)."""
    cache = tmp_path / "cache"
    cache.mkdir()
    if os.geteuid() != 0:
        cache.chmod(0o555)
        yield cache
        cache.chmod(0o755)
        return
    if (
        subprocess.run(
            ["mount", "-t", "tmpfs", "-o", "ro,size=64k", "tmpfs", str(cache)], capture_output=True
        ).returncode
        != 0
    ):
        pytest.skip("no read-only file system can be mounted here")
    yield cache
    subprocess.run(["umount", str(cache)], check=True)


@pytest.mark.parametrize("arguments", CACHE_COMMANDS, ids=["download", "record", "benchmark"])
def test_a_read_only_cache_is_one_line_naming_the_variable(arguments, read_only_cache, tmp_path, monkeypatch, capfd):
    monkeypatch.setenv("VIEWSLAM_CACHE", str(read_only_cache))
    monkeypatch.delenv("VIEWSLAM_DATA", raising=False)
    assert main([argument.format(tmp=tmp_path) for argument in arguments]) == 2
    error = capfd.readouterr().err
    assert error.count("\n") == 1 and f"VIEWSLAM_CACHE {read_only_cache}: cannot create" in error
    assert not list(read_only_cache.iterdir())
    assert not (tmp_path / "run.rrd").exists() and not list((tmp_path / "bench").glob("*"))


def test_a_bom_in_the_listings_is_read_like_any_text(excerpt, tmp_path):
    from viewer_slam.dataset.sources import open_source

    seq = shutil.copytree(excerpt, tmp_path / excerpt.name)
    for listing in ("rgb.txt", "depth.txt"):
        (seq / listing).write_bytes(b"\xef\xbb\xbf" + (seq / listing).read_bytes())
    assert len(open_source(seq)) == len(open_source(excerpt)) == 3


def test_groundtruth_beside_the_frames_is_a_warning_not_silence(excerpt, tmp_path, caplog):
    from viewer_slam.dataset.sources import open_source

    seq = shutil.copytree(excerpt, tmp_path / excerpt.name)
    (seq / "groundtruth.txt").write_text("1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 0 1\n")
    open_source(seq)
    assert [record.levelname for record in caplog.records] == ["WARNING"]
    assert "groundtruth.txt: no frame lies within the groundtruth's time span" in caplog.text
    caplog.clear()
    open_source(excerpt)
    assert not caplog.records


def png_chunks(data: bytes) -> list[bytes]:
    """The chunk types of a PNG, read with the format's own layout (length, type, data, CRC)."""
    kinds, offset = [], 8
    while offset < len(data):
        (length,) = struct.unpack(">I", data[offset : offset + 4])
        kinds.append(data[offset + 4 : offset + 8])
        assert (
            zlib.crc32(data[offset + 4 : offset + 8 + length])
            == struct.unpack(">I", data[offset + 8 + length : offset + 12 + length])[0]
        )
        offset += 12 + length
    return kinds


def test_the_png_check_accepts_every_image_of_the_real_excerpt(excerpt):
    from viewer_slam.dataset.sources import open_source

    for image in sorted((excerpt / "rgb").iterdir()) + sorted((excerpt / "depth").iterdir()):
        assert png_chunks(image.read_bytes())[-1] == b"IEND"
    frames = list(open_source(excerpt).frames())
    assert [frame.rgb.shape for frame in frames] == [(480, 640, 3)] * 3


def test_a_damaged_jpeg_is_read_without_libjpeg_noise(excerpt, tmp_path, capfd):
    import cv2
    import numpy as np

    from viewer_slam.dataset.sources import open_source

    seq = shutil.copytree(excerpt, tmp_path / excerpt.name)
    image = cv2.imread(str(first_image(seq, "rgb")))
    data = bytearray(cv2.imencode(".jpg", image)[1].tobytes())
    data[len(data) // 2 : len(data) // 2 + 20] = b"\xff\xd9" * 10  # an end marker inside the scan data
    first_image(seq, "rgb").write_bytes(bytes(data))
    frame = open_source(seq).frame(0)
    assert frame.rgb.shape == (480, 640, 3) and frame.rgb.dtype == np.uint8
    assert capfd.readouterr().err == ""


def bound_by_modes(command: list[str]) -> list[str]:
    """``command`` run so that file modes stop it: as is, or as root (whom modes do not stop) without the
    capabilities that override them."""
    if os.geteuid() != 0:
        return command
    if shutil.which("setpriv") is None:
        pytest.skip("root, and no setpriv to drop the capabilities that override file modes")
    return ["setpriv", "--bounding-set", "-dac_override,-dac_read_search", *command]


@pytest.mark.parametrize(
    "locked, mode", [("sequence", 0o000), ("parent", 0o600)], ids=["sequence-mode-000", "parent-without-x"]
)
def test_an_untraversable_sequence_folder_is_one_line_and_loses_nothing(locked, mode, excerpt, tmp_path):
    seq = shutil.copytree(excerpt, tmp_path / "parent" / excerpt.name)
    out = tmp_path / "out"
    out.mkdir()
    for name, content in EARLIER.items():
        (out / name).write_bytes(content)
    folder = seq if locked == "sequence" else seq.parent
    folder.chmod(mode)
    environment = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    try:
        assert subprocess.run(bound_by_modes(["test", "-r", str(seq / "rgb.txt")])).returncode == 1  # denied
        result = subprocess.run(
            bound_by_modes(
                [
                    sys.executable,
                    "-m",
                    "viewer_slam",
                    "record",
                    str(seq),
                    "--out",
                    str(out / "run.rrd"),
                    "--pipeline",
                    "rgbdslam",
                    "--quiet",
                ]
            ),
            capture_output=True,
            text=True,
            env=environment,
            timeout=120,
        )
    finally:
        folder.chmod(0o755)
    assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr
    assert result.stderr.startswith(f"viewslam: error: {seq}") and result.stderr.endswith(": Permission denied\n")
    assert snapshot(out) == EARLIER


# Nothing but our own lines on stderr: what native libraries print is held at its source.


def run_viewslam(
    *arguments, environment: dict[str, str] | None = None, timeout: float = 300
) -> subprocess.CompletedProcess:
    """``viewslam ARGUMENTS`` from this tree, in a process of its own, its output captured as bytes."""
    environment = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2]), **(environment or {})}
    return subprocess.run(
        [sys.executable, "-m", "viewer_slam", *map(str, arguments)],
        capture_output=True,
        env=environment,
        timeout=timeout,
    )


def test_a_bag_whose_depth_is_all_infinite_records_with_nothing_on_stderr(tmp_path):
    tiny_bag("inf.bag", depth=float("inf"), frames=6)(tmp_path, tmp_path)
    result = run_viewslam("record", tmp_path / "inf.bag", "--out", tmp_path / "run.rrd", "--quiet")
    assert result.returncode == 0 and result.stderr == b""  # NumPy warned of invalid values in matmul


def test_numpy_floating_point_warnings_never_reach_stderr(tmp_path, capfd):
    """Whatever computes on NaN or infinity during a command prints nothing of NumPy's."""
    import numpy as np

    import viewer_slam.cli.evaluate as evaluate

    real = evaluate.evaluate

    def noisy(*arguments, **options):
        np.array([np.inf]) - np.array([np.inf])  # "invalid value encountered in subtract"
        np.mean(np.array([]))  # "Mean of empty slice"
        return real(*arguments, **options)

    trajectory = tmp_path / "t.txt"
    trajectory.write_text("".join(f"{k / 10:.1f} {k / 100} 0 0 0 0 0 1\n" for k in range(30)))
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(evaluate, "evaluate", noisy)
        assert main(["evaluate", str(trajectory), str(trajectory)]) == 0
    assert capfd.readouterr().err == ""


def test_open3d_prints_errors_only():
    from viewer_slam.open3d_loader import import_open3d

    o3d = import_open3d()
    assert o3d.utility.get_verbosity_level() == o3d.utility.VerbosityLevel.Error


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="an X display is Linux's here")
def test_view_with_a_display_no_server_answers_is_one_line_naming_web(tmp_path):
    import rerun as rr

    display = next(f":{number}" for number in range(90, 200) if not Path(f"/tmp/.X11-unix/X{number}").exists())
    recording = tmp_path / "one.rrd"
    stream = rr.RecordingStream("viewslam-test")
    stream.save(recording)
    stream.log("point", rr.Points3D([[0.0, 0.0, 0.0]]))
    stream.disconnect()
    result = run_viewslam("view", recording, environment={"DISPLAY": display, "WAYLAND_DISPLAY": ""})
    error = result.stderr.decode()
    assert result.returncode == 2 and error.count("\n") == 1, error
    assert error.startswith(f"viewslam: error: {recording}: the viewer cannot open a window (") and "--web" in error


# Any locale: an output stream that cannot encode our text gets the nearest ASCII, never an error.

ENCODINGS = ["ascii", "latin-1"]


@pytest.mark.parametrize("encoding", ENCODINGS)
def test_record_prints_its_progress_and_summary_in_a_locale_without_utf8(excerpt, tmp_path, encoding):
    # A wide terminal: the long temporary path is printed on one line, as the check below reads it.
    result = run_viewslam(
        "record",
        excerpt,
        "--out",
        tmp_path / "run.rrd",
        "--pipeline",
        "rgbdslam",
        environment={"PYTHONIOENCODING": encoding, "COLUMNS": "400"},
    )
    assert result.returncode == 0, result.stderr
    printed = result.stdout.decode("ascii")  # nothing but ASCII: the table's rules, the dashes of no figure
    assert "rgbdslam" in printed and f"wrote {tmp_path / 'run.rrd'}" in printed and "+-" in printed
    assert "Traceback" not in result.stderr.decode(encoding) and "3/3" in result.stderr.decode("ascii")


@pytest.mark.parametrize("encoding", ENCODINGS)
def test_evaluate_and_the_lists_print_in_a_locale_without_utf8(excerpt, tmp_path, encoding):
    for arguments in (
        ["evaluate", excerpt / "groundtruth.txt", excerpt / "groundtruth.txt"],
        ["sequences"],
        ["pipelines"],
    ):
        result = run_viewslam(*arguments, environment={"PYTHONIOENCODING": encoding})
        assert result.returncode == 0 and result.stderr == b"", (arguments, result.stderr)
        # Their lines are echoed by click, which writes UTF-8 to a stream it takes for a misconfigured ASCII one.
        result.stdout.decode("utf-8" if encoding == "ascii" else encoding)


def test_diff_prints_its_table_in_a_locale_without_utf8(tmp_path, monkeypatch):
    from benchmark_fake_pipeline import MODULE, write_tum_folder

    from viewer_slam.pipelines import base

    monkeypatch.setitem(base.PIPELINE_MODULES, "fake", MODULE)
    sequence = write_tum_folder(tmp_path / "tiny", frames=4)
    assert main(["record", str(sequence), "--pipeline", "fake", "--out", str(tmp_path / "a.rrd"), "--quiet"]) == 0
    result = run_viewslam("diff", tmp_path / "a.json", tmp_path / "a.json", environment={"PYTHONIOENCODING": "ascii"})
    assert result.returncode == 0 and result.stderr == b"", result.stderr
    assert "frames/s" in result.stdout.decode("ascii") and " - " in result.stdout.decode("ascii")  # "—": no figure


def test_the_nearest_ascii_keeps_what_a_text_says():
    import io

    from viewer_slam.terminal import degrade_to_ascii

    stream = io.TextIOWrapper(io.BytesIO(), encoding="ascii")
    degrade_to_ascii(stream)
    stream.write("ATE — 3.1 mm … 5° ± 0.2, 3×, naïve ━━ 東")
    stream.flush()
    assert stream.buffer.getvalue() == b"ATE - 3.1 mm ... 5 deg +/- 0.2, 3x, naive -- ?"
