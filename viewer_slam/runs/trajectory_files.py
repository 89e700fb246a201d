"""Trajectory files scored against a groundtruth file with no sequence: what a recording of them alone shows.

Each estimate is scored exactly as ``viewslam evaluate GROUNDTRUTH ESTIMATE`` scores it
(TUM's association, rigid alignment, RPE over 1 s, coverage from the estimate's first pose
to the groundtruth's end, the lost-gap rule on the estimate's own rhythm), so the recording
and the report agree with ``evaluate`` to the digit. With no frames, the groundtruth's
poses stand in for them where a report needs a frame: a loss is placed at the first
groundtruth pose after the estimate's last one, and the report's sequence is the
groundtruth file.
"""

from dataclasses import dataclass, replace
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..evaluation.evaluation import Evaluation, evaluate, why_no_pairs
from ..evaluation.statistics import ErrorSeries
from ..geometry.rtabmap_database import RtabmapDatabase
from ..geometry.trajectory import Trajectory, read_tum
from ..geometry.trajectory_formats import TrajectoryFormat, detect_format, read_trajectory
from ..pipelines.edges import EdgeClassifier
from ..pipelines.run import PipelineRun
from .replay import no_pose_reason, read_estimate
from .report import pipeline_report, versions
from .rtabmap_graph import NodeEdge, edges_by_node, graph_events


@dataclass
class ScoredFile:
    """One estimate file, the format it was read as, and its scores; ``database`` the RTAB-Map
    database the file is, whose every pose is a graph node."""

    name: str
    path: Path
    format: TrajectoryFormat
    trajectory: Trajectory
    evaluation: Evaluation
    database: RtabmapDatabase | None = None

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
        coverage = self.evaluation.coverage
        start = coverage.span.start
        entries = []
        for lost_start, lost_end in coverage.lost_intervals:
            frame = min(int(np.searchsorted(groundtruth.timestamps, lost_start, side="right")), len(groundtruth) - 1)
            gap = lost_end - lost_start
            if coverage.stopped_at == lost_start:
                text = (f"{self.name} stopped at {lost_start - start:.1f} s of {coverage.span.end - start:.1f} s: "
                        f"no pose after it")
            else:
                text = f"{self.name} lost at {lost_start - start:.1f} s for {gap:.1f} s"
            entries.append({"frame": frame, "timestamp": float(groundtruth.timestamps[frame]),
                            "reason": no_pose_reason(self.path, gap), "text": text})
        return entries

    def report_block(self, groundtruth: Trajectory) -> dict[str, Any]:
        """The run report block of an estimate (``"source": "estimate"``): the same keys as ``record``'s."""
        run = PipelineRun(pipeline=self.name, parameters={"file": str(self.path), "format": self.format}, seed=0,
                          source="estimate", frames=len(self.trajectory), trajectory=self.trajectory,
                          tracking_lost=self.losses(groundtruth))
        if self.database is None:
            return pipeline_report(run, self.evaluation, None)
        classifier = EdgeClassifier()
        for index, node in enumerate(self.database.nodes):  # the database's poses are its nodes, in order
            for event in graph_events(node, self.edges[node.id], index, node.stamp, self.trajectory.poses[index],
                                      classifier):
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
        return {"sequence": {"name": self.name, "path": str(self.groundtruth_path), "frames": len(stamps),
                             "duration_s": float(stamps[-1] - stamps[0])},
                "interrupted": False, "versions": versions(),
                "pipelines": {run.name: run.report_block(self.groundtruth) for run in self.runs}}


def read_groundtruth(path: Path) -> Trajectory:
    """A groundtruth trajectory file, TUM or EuRoC (detected); every problem an :class:`InputError` naming it.

    A TUM file is read as ``evaluate`` reads its groundtruth: lines in time order after
    sorting (motion-capture exports repeat or reorder a stamp now and then).
    """
    path = Path(path)
    if path.is_dir():
        raise InputError.at(path, "is a folder; --groundtruth takes a trajectory file (a sequence folder is SEQUENCE)")
    return read_tum(path) if detect_format(path) is TrajectoryFormat.TUM else read_trajectory(path)[0]


def score_files(groundtruth_path: Path, estimates: list[tuple[str, Path]], format: TrajectoryFormat | None = None,
                name: str | None = None) -> ScoredFiles:
    """Read and score every ``(name, file)`` estimate (in ``format``, else detected) against the groundtruth file.

    ``name`` defaults to the groundtruth file's name without its extension. An estimate
    with no pose pair is an :class:`InputError` naming it and saying why.
    """
    groundtruth = read_groundtruth(groundtruth_path)
    runs = []
    for run_name, path in estimates:
        trajectory, detected, database = read_estimate(Path(path), format)
        evaluation = evaluate(groundtruth, trajectory)
        if evaluation.ate is None:
            raise InputError.at(path, why_no_pairs(groundtruth, trajectory))
        runs.append(ScoredFile(run_name, Path(path), detected, trajectory, evaluation, database))
    return ScoredFiles(name or Path(groundtruth_path).stem, Path(groundtruth_path), groundtruth, runs)
