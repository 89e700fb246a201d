"""Every reader, fed nested, truncated and mistyped variants of a good file (hypothesis): it reads
the file or raises the one-line InputError naming it; nothing else escapes, and nothing of a
native library reaches stderr."""

import json
import os
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from viewer_slam.errors import InputError

CAMERA = {
    "fx": 517.3,
    "fy": 516.5,
    "cx": 318.6,
    "cy": 255.3,
    "width": 640,
    "height": 480,
    "depth_factor": 5000.0,
    "distortion": [0.26, -0.95, -0.005, 0.003, 1.16],
}
CONFIG = '[rgbdslam]\nmax_keypoints = 600\nnn_distance_ratio = 0.6\n\n[rtabmap]\n"Vis/MaxFeatures" = 400\n'
SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])

# Values of every JSON type, including the awkward ones: a number too long to convert, an infinity.
json_values = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(2**70), 2**70)
    | st.floats()
    | st.text(max_size=8)
    | st.just(int("9" * 40)),
    lambda children: st.lists(children, max_size=3) | st.dictionaries(st.text(max_size=4), children, max_size=3),
    max_leaves=6,
)


def paths_into(value, prefix=()) -> list[tuple]:
    """Every path (keys and indices) to a value inside ``value``, ``()`` the whole."""
    paths = [prefix]
    children = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for key, child in children:
        paths += paths_into(child, (*prefix, key))
    return paths


def replaced(value, path: tuple, new):
    """``value`` with the value at ``path`` replaced by ``new`` (a copy)."""
    if not path:
        return new
    copy = json.loads(json.dumps(value))
    target = copy
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = new
    return copy


@st.composite
def json_variants(draw, good) -> str:
    """The text of ``good`` nested, mistyped or truncated at a point hypothesis chooses."""
    kind = draw(st.sampled_from(["nested", "nested-text", "mistyped", "truncated"]))
    text = json.dumps(good)
    if kind == "nested":
        path = draw(st.sampled_from(paths_into(good)))
        depth = draw(st.integers(1, 120))
        inner = json.loads(json.dumps(good))
        for key in path:
            inner = inner[key]
        return json.dumps(replaced(good, path, json.loads("[" * depth + json.dumps(inner) + "]" * depth)))
    if kind == "nested-text":
        depth = draw(st.integers(1, 200_000))
        return draw(st.sampled_from(["[", '{"a":'])) * depth + "1"
    if kind == "mistyped":
        return json.dumps(replaced(good, draw(st.sampled_from(paths_into(good))), draw(json_values)), allow_nan=True)
    return text[: draw(st.integers(0, len(text) - 1))]


toml_literals = st.sampled_from(
    [
        '"text"',
        "true",
        "1.5",
        "-7",
        "nan",
        "inf",
        "[1, 2]",
        "{a = 1}",
        "1979-05-27",
        "9" * 5000,
        "0x7fffffffffffffff",
        "[[1], [2]]",
        '"""',
    ]
)


@st.composite
def toml_variants(draw) -> str:
    kind = draw(st.sampled_from(["nested", "nested-tables", "mistyped", "truncated"]))
    if kind == "nested":
        return f"max_keypoints = {'[' * draw(st.integers(1, 20_000))}1"
    if kind == "nested-tables":
        return "[" + ".".join(["a"] * draw(st.integers(1, 5000))) + "]\nb = 1\n"
    if kind == "mistyped":
        lines = CONFIG.splitlines()
        index = draw(st.sampled_from([i for i, line in enumerate(lines) if " = " in line]))
        lines[index] = lines[index].split(" = ")[0] + " = " + draw(toml_literals)
        return "\n".join(lines) + "\n"
    return CONFIG[: draw(st.integers(0, len(CONFIG) - 1))]


def reads_or_names(path: Path, read: Callable[[], object], capfd) -> None:
    """``read()`` returns, or raises InputError whose one line names ``path``; stderr stays empty."""
    try:
        read()
    except InputError as error:
        assert str(error).startswith(str(path)) and "\n" not in str(error), str(error)
    assert capfd.readouterr().err == ""


@SETTINGS
@given(text=json_variants(CAMERA))
def test_camera_json_reader(text, capfd):
    from viewer_slam.geometry.camera import Camera

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "camera.json"
        path.write_text(text)
        reads_or_names(path, lambda: Camera.load(path), capfd)


@SETTINGS
@given(text=toml_variants())
def test_config_reader(text, capfd):
    from viewer_slam.pipelines.base import pipeline_class
    from viewer_slam.pipelines.params import resolve_params

    types = {name: pipeline_class(name).Params for name in ("rgbdslam", "rtabmap")}
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "c.toml"
        path.write_text(text)
        try:
            resolve_params(types, config=path)
        except InputError as error:  # a parameter's value is named by the file and the parameter
            assert str(error).startswith(str(path)) and "\n" not in str(error), str(error)
        assert capfd.readouterr().err == ""


@pytest.fixture(scope="module")
def report(tmp_path_factory) -> Path:
    """A report of a 4-frame run of the scripted pipeline, and its trajectory beside it."""
    from benchmark_fake_pipeline import recorded_report as record_fake

    return record_fake(tmp_path_factory.mktemp("run"))


@SETTINGS
@given(data=st.data())
def test_report_reader_and_the_comparison(report, data, capfd):
    """What `diff` reads of a report: loaded, then compared with the good report, both ways."""
    from viewer_slam.comparison import compare_reports, comparison_to_dict

    text = data.draw(json_variants(json.loads(report.read_text())))
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "b.json"
        path.write_text(text)
        shutil.copy(report.with_name("a.fake.txt"), Path(folder) / "b.fake.txt")

        def compare():
            for pair in ((report, path), (path, report)):
                comparison_to_dict(compare_reports(*pair))

        try:
            compare()
        except InputError as error:  # names the report (b.json), its trajectory (b.RUN.txt), or both reports
            assert str(path.with_suffix("")) in str(error) and "\n" not in str(error), str(error)
        assert capfd.readouterr().err == ""


def png_and_jpeg() -> dict[str, bytes]:
    import cv2

    image = (np.random.default_rng(0).random((48, 64, 3)) * 255).astype(np.uint8)
    return {suffix: cv2.imencode(suffix, image)[1].tobytes() for suffix in (".png", ".jpg")}


IMAGES = png_and_jpeg()


@st.composite
def damaged_images(draw) -> bytes:
    data = bytearray(IMAGES[draw(st.sampled_from(sorted(IMAGES)))])
    kind = draw(st.sampled_from(["truncated", "first-marker", "flipped"]))
    if kind == "truncated":
        return bytes(data[: draw(st.integers(0, len(data) - 1))])
    if kind == "first-marker":  # a marker of another kind (or none) after the signature
        data[3] = draw(st.integers(0, 255))
        return bytes(data)
    for _ in range(draw(st.integers(1, 4))):
        offset = draw(st.integers(0, len(data) - 1))
        data[offset] = draw(st.integers(0, 255))
    return bytes(data)


@SETTINGS
@given(data=damaged_images())
def test_image_reader(data, capfd):
    from viewer_slam.dataset.tum import TumSequence

    def size(width: int, height: int) -> None:
        if (width, height) != (64, 48):
            raise InputError.at(path, f"image is {width}x{height}")

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "rgb.png"
        path.write_bytes(data)
        reads_or_names(path, lambda: TumSequence._read_image(path, colour=True, size=size), capfd)


@pytest.fixture(scope="module")
def bag(tmp_path_factory) -> bytes:
    """The bytes of a ROS 1 bag of four 32x24 frames."""
    from bag_writer import BagWriter

    path = tmp_path_factory.mktemp("bag") / "b.bag"
    rng = np.random.default_rng(0)
    with BagWriter(path, 1) as writer:
        for k in range(4):
            stamp = 5 * 10**9 + k * 33_333_333
            writer.image("/cam/rgb", stamp, "cam", rng.integers(0, 256, (24, 32, 3), dtype=np.uint8), "bgr8")
            writer.camera_info("/cam/camera_info", stamp, "cam", 32, 24, (40.0, 41.0, 15.5, 11.5), (0, 0, 0, 0, 0))
            writer.image("/cam/depth", stamp + 1000, "cam", rng.uniform(0.5, 3, (24, 32)).astype(np.float32), "32FC1")
    return path.read_bytes()


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_bag_reader(bag, data, capfd):
    from viewer_slam.dataset.sources import open_source

    damaged = bytearray(bag)
    if data.draw(st.booleans(), label="truncate"):
        del damaged[data.draw(st.integers(0, len(bag) - 1), label="at") :]
    else:
        for _ in range(data.draw(st.integers(1, 8), label="flips")):
            offset = data.draw(st.integers(0, len(bag) - 1), label="offset")
            damaged[offset] ^= data.draw(st.integers(1, 255), label="bits")
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "b.bag"
        path.write_bytes(bytes(damaged))

        def read():
            for frame in open_source(path).frames():
                assert np.isfinite(frame.depth).all() and frame.depth.max() <= 1000

        reads_or_names(path, read, capfd)
    assert not os.path.exists(path)
