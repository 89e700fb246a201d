"""Takes the viewer screenshots of docs/images/ from recordings made as a user would make them.

    python -m scripts.viewer_screenshots [demo] [fr1_rpy_200] [diff] [study_kidnap]

Each recording is made by the commands listed in FIGURES (in a temporary folder, with this
interpreter's viewslam), then opened by the Rerun viewer under Xvfb at 1920x1080 and
1280x800 (`xvfb-run -a rerun --screenshot-to shot.png --window-size WxH FILE.rrd`, on a port
of its own, with RUST_LOG=error: its start-up warnings would otherwise show as notices over
the top right of the window). The viewer draws at twice the window's size; the picture is scaled back to the
window's size and stored with a 256-colour palette. Needs xvfb-run (Debian package xvfb), a
Vulkan driver for the viewer (Debian package mesa-vulkan-drivers: Mesa's software OpenGL
cannot draw the R32Float textures the viewer needs) and,
for `fr1_rpy_200`, the 200-frame fr1/rpy excerpt beside the repository
(../shared/data/tum/rgbd_dataset_freiburg1_rpy_200); for `study_kidnap` (a recording of
trajectory files alone), the study's fr2/360_kidnap runs (../shared/data/study_kasar2018).
"""

import argparse
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
from pathlib import Path

import viewer_slam.code_paths  # noqa: F401  (before NumPy loads: holds it to one code path)

import numpy as np
from PIL import Image

from benchmarks.figures import REPO, SHARED_DATA, TUM

IMAGES = REPO / "docs" / "images"
VIEWSLAM = Path(sys.executable).with_name("viewslam")
RERUN = Path(sys.executable).with_name("rerun")
RPY_200 = TUM / "rgbd_dataset_freiburg1_rpy_200"
KIDNAP = SHARED_DATA / "study_kasar2018" / "freiburg2_360_kidnap"
SIZES = ("1920x1080", "1280x800")
PER_FRAME = ("demo", "fr1_rpy_200")  # recordings of a sequence's frames: their size per frame is reported

# name -> (commands, the recording they write, the image name at 1920x1080)
FIGURES = {
    "demo": ([["record", "--out", "demo.rrd", "--quiet"]], "demo.rrd", "viewer_demo.png"),
    "fr1_rpy_200": (
        [["record", str(RPY_200), "--out", "rpy200.rrd", "--quiet"]],
        "rpy200.rrd",
        "viewer_fr1_rpy_200.png",
    ),
    "diff": (
        [
            ["synth", "360_kidnap", "--out", "kidnap", "--frames", "120", "--resolution", "320x240"],
            [
                "record",
                "kidnap",
                "--pipeline",
                "rtabmap",
                "--param",
                "Rtabmap/DetectionRate=5",
                "--param",
                "Odom/ResetCountdown=0",
                "--out",
                "runs/reset0.rrd",
                "--quiet",
            ],
            [
                "record",
                "kidnap",
                "--pipeline",
                "rtabmap",
                "--param",
                "Rtabmap/DetectionRate=5",
                "--param",
                "Odom/ResetCountdown=5",
                "--out",
                "runs/reset5.rrd",
                "--quiet",
            ],
            ["diff", "runs/reset0.json", "runs/reset5.json", "--json", "runs/diff.json", "--out", "runs/diff.rrd"],
        ],
        "runs/diff.rrd",
        "diff.png",
    ),
    "study_kidnap": (
        [
            [
                "record",
                "--groundtruth",
                str(KIDNAP / "rgbd" / "groundtruth.txt"),
                "--estimate",
                f"rgbdslam_v2={KIDNAP / 'rgbd' / 'rgbd_poses.txt'}",
                "--estimate",
                f"rtabmap={KIDNAP / 'rtab' / 'rtabmap_poses.txt'}",
                "--out",
                "kidnap.rrd",
                "--quiet",
            ]
        ],
        "kidnap.rrd",
        "viewer_study_kidnap.png",
    ),
}


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def has_notice(image: Image.Image) -> bool:
    """Whether the viewer's start-up notices (running in a container, software rasteriser) cover
    the window's top right: their warning icon, an orange disc, 317 pixels left of the edge."""
    width = image.width
    icon = np.asarray(image.crop((width - 330, 35, width - 300, 70)), dtype=int)
    return int((np.abs(icon - (252, 138, 2)).sum(axis=2) < 40).sum()) >= 20


def screenshot(recording: Path, size: str, out: Path, attempts: int = 4) -> None:
    """``recording`` in the Rerun viewer at window ``size``, saved to ``out`` at that size
    (taken again while the viewer's start-up notices cover part of it)."""
    width, height = map(int, size.split("x"))
    for _ in range(attempts):
        with tempfile.TemporaryDirectory() as folder:
            shot = Path(folder) / "shot.png"
            subprocess.run(
                [
                    "xvfb-run",
                    "-a",
                    "-s",
                    "-screen 0 6600x2400x24",
                    str(RERUN),
                    "--port",
                    str(free_port()),
                    "--screenshot-to",
                    str(shot),
                    "--window-size",
                    size,
                    str(recording),
                ],
                check=True,
                capture_output=True,
                timeout=600,
                env={**os.environ, "RUST_LOG": "error"},
            )  # warnings would show as notices
            image = Image.open(shot).convert("RGB").resize((width, height), Image.Resampling.LANCZOS)
        if not has_notice(image):
            break
    image.quantize(256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE).save(out, optimize=True)


def image_name(name: str, size: str) -> str:
    stem = Path(FIGURES[name][2]).stem
    return f"{stem}.png" if size == SIZES[0] else f"{stem}_{size}.png"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m scripts.viewer_screenshots", description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", help=f"figures to take (default: all): {', '.join(FIGURES)}")
    names = parser.parse_args(argv).names or list(FIGURES)
    if unknown := sorted(set(names) - set(FIGURES)):
        parser.error(f"unknown figure {', '.join(unknown)}; choose from {', '.join(FIGURES)}")
    if shutil.which("xvfb-run") is None:
        print("xvfb-run is missing (Debian package xvfb)", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory(prefix="viewslam-shots-") as folder:
        for name in names:
            commands, recording, _ = FIGURES[name]
            for command in commands:
                subprocess.run([str(VIEWSLAM), *command], cwd=folder, check=True, stdout=subprocess.DEVNULL)
            rrd = Path(folder) / recording
            frames = (
                json.loads(rrd.with_suffix(".json").read_text())["sequence"]["frames"] if name in PER_FRAME else None
            )
            per_frame = f", {rrd.stat().st_size / frames / 1024:.1f} KiB per frame" if frames else ""
            print(f"{name}: {rrd.stat().st_size} bytes{per_frame}")
            for size in SIZES:
                out = IMAGES / image_name(name, size)
                screenshot(Path(folder) / recording, size, out)
                print(f"{out.relative_to(REPO)}  ({name}, {size})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
