"""The `viewslam record` command line as data, and what a record gives back."""

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..geometry.trajectory_formats import TrajectoryFormat
from ..runs.service import ScoredRun

# open_bag's keywords and the flags that set them.
BAG_FLAGS = {"rgb_topic": "--rgb-topic", "depth_topic": "--depth-topic", "camera_info_topic": "--camera-info-topic",
             "groundtruth": "--groundtruth", "groundtruth_topic": "--groundtruth-topic"}
BagOptions = dict[str, Any]


@dataclass
class RecordOptions:
    """The `viewslam record` command line, as data. ``sequence=None`` is the built-in demo.

    ``pipeline=None`` runs both built-in pipelines, or none when there are ``estimates``
    (``NAME=FILE`` each, read in ``format`` or a detected one). The bag options apply to a
    ROS bag only (see :func:`~viewer_slam.dataset.rosbag.open_bag`).
    """

    sequence: str | None = None
    pipeline: str | None = None
    out: Path | None = None
    max_frames: int | None = None
    stride: int = 1
    params: list[str] = field(default_factory=list)
    config: Path | None = None
    seed: int = 0
    quiet: bool = False
    spawn: bool = False
    connect: str | None = None
    estimates: list[str] = field(default_factory=list)
    format: TrajectoryFormat | None = None
    bag: BagOptions = field(default_factory=dict)


@dataclass
class RecordResult:
    """What a record wrote (``written``, the files that exist) and the report it wrote; ``scored`` holds
    each run's scores for a caller that goes on with them (a benchmark task).
    """

    recording: Path
    report_path: Path
    trajectories: dict[str, Path]
    report: dict[str, Any]
    written: list[Path] = field(default_factory=list)
    scored: dict[str, ScoredRun] = field(default_factory=dict)

    @property
    def interrupted(self) -> bool:
        return self.report["interrupted"]
