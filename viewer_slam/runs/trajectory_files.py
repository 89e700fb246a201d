"""Trajectory files scored against a groundtruth: the one scoring path of ``evaluate``,
``record --groundtruth`` and ``study``.

Every command that scores files reads them here, so they all accept the same inputs: a
groundtruth that is a trajectory file (TUM or EuRoC, detected), a TUM sequence folder or a ROS
bag (whose frames give the clock: the coverage span, the frame period and a KITTI file's
times), and estimates that are trajectory files (TUM, KITTI, EuRoC), RTAB-Map databases or a
ROS bag's pose topic. Each estimate is scored with :class:`ScoringOptions`; the defaults are
``viewslam evaluate``'s (TUM's association, rigid alignment, RPE over 1 s, coverage from the
estimate's first pose to the groundtruth's end, the lost-gap rule on the estimate's own
rhythm), so a recording of files and ``evaluate`` agree to the digit.

With no frames, the groundtruth's poses stand in for them where a report needs a frame: a
loss is placed at the first groundtruth pose after the estimate's last one, and the report's
sequence is the groundtruth file.
"""

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from ..dataset.sources import open_source
from ..errors import InputError
from ..evaluation.alignment import Alignment
from ..evaluation.coverage import Span
from ..evaluation.evaluation import Evaluation, RpeMode, evaluate, why_no_pairs
from ..evaluation.rpe import DeltaUnit
from ..evaluation.statistics import ErrorSeries
from ..geometry.rtabmap_database import RtabmapDatabase
from ..geometry.trajectory import Trajectory, read_tum
from ..geometry.trajectory_formats import TrajectoryFormat, detect_format, read_estimate, read_trajectory
from ..pipelines.edges import EdgeClassifier
from ..pipelines.run import PipelineRun
from .rtabmap_graph import NodeEdge, edges_by_node, graph_events
from .run_report import pipeline_report, versions

SEQUENCE_RULE = "sequence frames"
BAG_FORMAT = "bag"  # an estimate read from a ROS bag's pose topic


@dataclass(frozen=True)
class Clock:
    """What a sequence tells about time: the coverage span, the frame period and the frame stamps
    (a KITTI file's times). None: unknown (a bare groundtruth file)."""

    span: Span | None = None
    frame_period: float | None = None
    frame_stamps: np.ndarray | None = None


@dataclass(frozen=True)
class ScoringOptions:
    """How every estimate is scored (the options of ``viewslam evaluate``; see
    :func:`~viewer_slam.evaluation.evaluation.evaluate`). ``span`` overrides the coverage span
    the clock gives."""

    max_difference: float = 0.02
    offset: float = 0.0
    align: Alignment = Alignment.RIGID
    delta: float = 1.0
    delta_unit: DeltaUnit = DeltaUnit.SECONDS
    all_deltas: bool = False
    rpe_mode: RpeMode = RpeMode.DELTA
    span: Span | None = None


@dataclass(frozen=True)
class Groundtruth:
    """A groundtruth trajectory, where it was read from, and the clock of its sequence's frames."""

    path: Path
    trajectory: Trajectory
    clock: Clock = field(default_factory=Clock)


@dataclass(frozen=True)
class EstimateFile:
    """An estimate as read: its trajectory, the format it was read as (a :class:`TrajectoryFormat`,
    or ``"bag"``) and, for an RTAB-Map database, the database, whose every pose is a graph node."""

    path: Path
    trajectory: Trajectory
    format: str
    database: RtabmapDatabase | None = None


@dataclass
class ScoredFile:
    """One estimate, named ``name`` in reports, and its scores."""

    name: str
    estimate: EstimateFile
    evaluation: Evaluation

    @property
    def path(self) -> Path:
        return self.estimate.path

    @property
    def format(self) -> str:
        return self.estimate.format

    @property
    def trajectory(self) -> Trajectory:
        return self.estimate.trajectory

    @property
    def database(self) -> RtabmapDatabase | None:
        return self.estimate.database

    @cached_property
    def edges(self) -> dict[int, list[NodeEdge]]:
        """The database's graph edges by node id (:func:`~.rtabmap_graph.edges_by_node`; none for a file)."""
        return edges_by_node(self.database) if self.database is not None else {}

    @property
    def ate(self) -> ErrorSeries:
        """The per-pose ATE: a scored file has pose pairs (:func:`score_files` refuses one without)."""
        assert self.evaluation.ate is not None
        return self.evaluation.ate

    @property
    def alignment(self) -> np.ndarray:
        """The rigid transform from the file's frame onto the groundtruth's that its ATE was scored under."""
        assert self.evaluation.alignment is not None
        return self.evaluation.alignment

    def pose_errors(self) -> np.ndarray:
        """The ATE error of each pose, NaN for a pose without a groundtruth pair."""
        return self.evaluation.pose_errors(len(self.trajectory))

    def losses(self, groundtruth: Trajectory) -> list[dict[str, Any]]:
        """The report's ``tracking_lost`` entries: one per lost interval, at the first groundtruth pose in it."""
        from .replay import no_pose_reason  # the replay's parameters (pydantic) load only for a report

        coverage = self.evaluation.coverage
        start = coverage.span.start
        entries = []
        for lost_start, lost_end in coverage.lost_intervals:
            frame = min(int(np.searchsorted(groundtruth.timestamps, lost_start, side="right")), len(groundtruth) - 1)
            gap = lost_end - lost_start
            if coverage.stopped_at == lost_start:
                text = (
                    f"{self.name} stopped at {lost_start - start:.1f} s of {coverage.span.end - start:.1f} s: "
                    f"no pose after it"
                )
            else:
                text = f"{self.name} lost at {lost_start - start:.1f} s for {gap:.1f} s"
            entries.append(
                {
                    "frame": frame,
                    "timestamp": float(groundtruth.timestamps[frame]),
                    "reason": no_pose_reason(self.path, gap),
                    "text": text,
                }
            )
        return entries

    def report_block(self, groundtruth: Trajectory) -> dict[str, Any]:
        """The run report block of an estimate (``"source": "estimate"``): the same keys as ``record``'s."""
        run = PipelineRun(
            pipeline=self.name,
            parameters={"file": str(self.path), "format": self.format},
            seed=0,
            source="estimate",
            frames=len(self.trajectory),
            trajectory=self.trajectory,
            tracking_lost=self.losses(groundtruth),
        )
        if self.database is None:
            return pipeline_report(run, self.evaluation, None)
        classifier = EdgeClassifier()
        for index, node in enumerate(self.database.nodes):  # the database's poses are its nodes, in order
            for event in graph_events(
                node, self.edges[node.id], index, node.stamp, self.trajectory.poses[index], classifier
            ):
                run.observe(event)
        return pipeline_report(run, replace(self.evaluation, node_ate=self.evaluation.ate), None)


@dataclass
class ScoredFiles:
    """A groundtruth file and the estimates scored against it; ``name`` names them in reports and titles."""

    name: str
    groundtruth_path: Path
    groundtruth: Trajectory
    runs: list[ScoredFile]

    def report(self) -> dict[str, Any]:
        """The run report (``report.schema.json``), its sequence the groundtruth file."""
        stamps = self.groundtruth.timestamps
        return {
            "sequence": {
                "name": self.name,
                "path": str(self.groundtruth_path),
                "frames": len(stamps),
                "duration_s": float(stamps[-1] - stamps[0]),
            },
            "interrupted": False,
            "versions": versions(),
            "pipelines": {run.name: run.report_block(self.groundtruth) for run in self.runs},
        }


def read_groundtruth(path: Path, topic: str | None = None) -> Groundtruth:
    """A groundtruth: a trajectory file (TUM or EuRoC, detected), a TUM sequence folder's or a ROS
    bag's, with the clock of the sequence's frames where there are frames; ``topic`` names a bag's
    pose topic. Every problem is an :class:`InputError` naming the file.

    A TUM file is read with its lines in time order after sorting (motion-capture exports repeat
    or reorder a stamp now and then).
    """
    from ..dataset.rosbag import is_bag  # the bag reader itself loads only for a bag

    path = Path(path)
    if is_bag(path):
        from ..dataset.rosbag import open_groundtruth

        trajectory, sequence = open_groundtruth(path, groundtruth_topic=topic)
        return Groundtruth(path, trajectory, Clock() if sequence is None else sequence_clock(sequence))
    if topic is not None:
        raise InputError(f"--groundtruth-topic: only for a ROS bag, and {path} is not one")
    if path.is_dir():
        folder = open_source(path)
        if folder.groundtruth is None:
            raise InputError.at(path, "sequence has no groundtruth.txt")
        return Groundtruth(path, folder.groundtruth, sequence_clock(folder))
    trajectory = read_tum(path) if detect_format(path) is TrajectoryFormat.TUM else read_trajectory(path)[0]
    return Groundtruth(path, trajectory)


def read_sequence_clock(path: Path) -> Clock:
    """The clock of the frames of the TUM sequence folder or ROS bag ``path``."""
    from ..dataset.rosbag import is_bag

    if not Path(path).is_dir() and not is_bag(path):
        raise InputError(f"--sequence {path}: not a folder or a ROS bag")
    return sequence_clock(open_source(path))


def sequence_clock(sequence: Any) -> Clock:
    """Coverage over the time the camera recorded, in units of its frame period."""
    stamps = np.asarray(sequence.timestamps, dtype=np.float64)
    return Clock(Span(float(stamps[0]), float(stamps[-1]), SEQUENCE_RULE), sequence.frame_period, stamps)


def read_estimate_file(
    path: Path, format: str | None = None, clock: Clock = Clock(), topic: str | None = None
) -> EstimateFile:
    """An estimate: a ROS bag's pose topic (``topic``, else its only one), else a file in ``format``
    or a detected one (a KITTI file timed by the ``clock``'s frames)."""
    from ..dataset.rosbag import is_bag

    path = Path(path)
    if is_bag(path):
        from ..dataset.rosbag import bag_poses

        return EstimateFile(path, bag_poses(path, topic, option="--estimate-topic"), BAG_FORMAT)
    trajectory, detected, database = read_estimate(path, format, clock.frame_stamps)
    return EstimateFile(path, trajectory, detected, database)


def score_estimate(
    groundtruth: Groundtruth, estimate: EstimateFile, options: ScoringOptions = ScoringOptions()
) -> Evaluation:
    """The scores of ``estimate`` against ``groundtruth``; an estimate with no pose pair is an
    :class:`InputError` naming it and saying why."""
    clock = groundtruth.clock
    evaluation = evaluate(
        groundtruth.trajectory,
        estimate.trajectory,
        max_difference=options.max_difference,
        offset=options.offset,
        align=options.align,
        delta=options.delta,
        delta_unit=options.delta_unit,
        all_deltas=options.all_deltas,
        span=options.span or clock.span,
        frame_period=clock.frame_period,
        rpe_mode=options.rpe_mode,
    )
    if evaluation.ate is None:
        raise InputError.at(
            estimate.path,
            why_no_pairs(groundtruth.trajectory, estimate.trajectory, options.offset, options.max_difference),
        )
    return evaluation


def score_files(
    groundtruth: Groundtruth,
    estimates: Sequence[tuple[str, Path]],
    format: str | None = None,
    *,
    options: ScoringOptions = ScoringOptions(),
    topic: str | None = None,
    name: str | None = None,
) -> ScoredFiles:
    """Read every ``(name, file)`` estimate (:func:`read_estimate_file`), then score each against
    ``groundtruth`` (:func:`score_estimate`).

    ``name`` names the groundtruth in reports (default: its file name without the extension).
    """
    read = [(run, read_estimate_file(path, format, groundtruth.clock, topic)) for run, path in estimates]
    runs = [ScoredFile(run, estimate, score_estimate(groundtruth, estimate, options)) for run, estimate in read]
    return ScoredFiles(name or groundtruth.path.stem, groundtruth.path, groundtruth.trajectory, runs)
