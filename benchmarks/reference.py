"""The real RTAB-Map 0.23.8's runs beside the repository, as like_for_like and first_registration read them.

The reference (``../shared/data/reference/rtabmap-0.23.8``) holds the original's runs, one
folder per sequence and mode: ``<sequence>-perframe`` (a node every frame) and
``<sequence>-default``, the synthetic ones under ``synthetic/``. Each folder holds the
original's optimised graph (``poses_tum.txt``), its odometry (``db_poses_odom_tum.txt``), its
nodes and links (``nodes.csv``, ``links.csv``), for synthetic runs the odometry of every
frame (``frames.csv``), and ``summary.json``; beside the folders, the SHA-256 list of each
sequence's frames (``<sequence>.sha256``).
"""

import csv
import hashlib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from viewer_slam.errors import InputError
from viewer_slam.geometry.camera import Camera

from .figures import SHARED_DATA

REFERENCE = SHARED_DATA / "reference" / "rtabmap-0.23.8"
REFERENCE_NAME = "rtabmap-0.23.8"
PER_FRAME = {"Rtabmap/DetectionRate": 0, "RGBD/LinearUpdate": 0, "RGBD/AngularUpdate": 0}
"""A node on every frame: the ``perframe`` mode."""
THAT_BUILD = {"OdomF2M/BundleAdjustment": 0, "Vis/BundleAdjustment": 0, "Vis/PnPRefineIterations": 1}
"""The reference's build has no g2o: neither bundle adjustment, and its default of one PnP
refinement (``Parameters.h`` without ``RTABMAP_G2O``)."""


@dataclass
class ReferenceRun:
    folder: Path
    sequence: str  # the folder name of the frames
    mode: str  # "perframe" or "default"
    synthetic: bool

    @property
    def name(self) -> str:
        return self.folder.name

    @property
    def overrides(self) -> dict[str, Any]:
        """The original's configuration of this run, in its parameter names."""
        return {**THAT_BUILD, **(PER_FRAME if self.mode == "perframe" else {})}


def reference_runs(reference: Path) -> list[ReferenceRun]:
    runs = []
    for folder in sorted(
        [
            *reference.glob("*-perframe"),
            *reference.glob("*-default"),
            *(reference / "synthetic").glob("*-perframe"),
            *(reference / "synthetic").glob("*-default"),
        ]
    ):
        sequence, _, mode = folder.name.rpartition("-")
        runs.append(ReferenceRun(folder, sequence, mode, folder.parent.name == "synthetic"))
    return runs


def scene_name(sequence: str) -> str:
    """``rgbd_dataset_freiburg2_synth_360_kidnap`` -> ``360_kidnap``."""
    return sequence.split("_synth_", 1)[1] if "_synth_" in sequence else sequence


def frames_folder(run: ReferenceRun, tum: Path, synthetic: Path | None) -> Path:
    """The folder of the frames the original ran on: a TUM folder under ``tum``, or a rendered
    synthetic scene under ``synthetic``."""
    if not run.synthetic:
        return tum / run.sequence
    if synthetic is None:
        raise InputError(
            f"{run.name}: a synthetic scene; render it (viewslam synth {scene_name(run.sequence)} "
            f"--out DIR/{run.sequence} --resolution 640x480 --seed 0) and pass --synthetic DIR"
        )
    for candidate in (synthetic / run.sequence, synthetic / scene_name(run.sequence)):
        if candidate.is_dir():
            return candidate
    raise InputError(f"{synthetic}: no {run.sequence} (or {scene_name(run.sequence)}) for {run.name}")


def same_frames(run: ReferenceRun, folder: Path) -> tuple[int, int, int]:
    """(files listed, files equal, rgb/depth PNGs that differ) against the reference's SHA-256 list."""
    listing = run.folder.parent / f"{run.sequence}.sha256"
    if not listing.is_file():
        return 0, 0, 0
    listed = equal = images = 0
    for line in listing.read_text().splitlines():
        digest, _, name = line.partition("  ")
        path = folder / name
        listed += 1
        if path.is_file() and hashlib.sha256(path.read_bytes()).hexdigest() == digest:
            equal += 1
        elif name.endswith(".png"):
            images += 1
    return listed, equal, images


def reference_camera(sequence_camera: Camera) -> Camera:
    """The intrinsics the original used: the same focal lengths and centre, no distortion (its
    dataset tool reads no distortion coefficients)."""
    return replace(sequence_camera, distortion=(0.0,) * 5)


def camera_view(folder: Path, camera: Camera, into: Path) -> Path:
    """A folder of the same name whose files link to ``folder``'s, with ``camera`` in camera.json."""
    view = into / folder.name
    view.mkdir(parents=True, exist_ok=True)
    for item in folder.iterdir():
        if item.name != "camera.json" and not (view / item.name).exists():
            (view / item.name).symlink_to(item.resolve())
    camera.save(view / "camera.json")
    return view


def read_nodes(run: ReferenceRun) -> list[dict[str, str]]:
    with open(run.folder / "nodes.csv", newline="") as file:
        return list(csv.DictReader(file))


def read_links(run: ReferenceRun) -> list[dict[str, str]]:
    with open(run.folder / "links.csv", newline="") as file:
        return list(csv.DictReader(file))


def number(text: str | None) -> float:
    """A CSV cell as a number, NaN where it is empty."""
    return float(text) if text else float("nan")


def frame_rows(run: ReferenceRun) -> list[dict[str, str]]:
    """The original's per-frame rows (frames.csv: odometry, lost flag, node, map), or none."""
    frames_csv = run.folder / "frames.csv"
    if not frames_csv.is_file():
        return []
    with open(frames_csv, newline="") as file:
        return list(csv.DictReader(file))
