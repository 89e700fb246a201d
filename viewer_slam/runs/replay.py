"""An estimate from another system (a trajectory file) replayed as a run over its sequence.

The replay emits the events a pipeline would have: one ``FrameTracked`` per processed
frame, carrying the estimate's pose associated with the frame's stamp (TUM's rule, within
0.02 s) or none; ``TrackingLost`` / ``TrackingRecovered`` around every stretch without
poses that the coverage score counts as lost (its gap rule, on the processed frames'
period), so the tracking-state timeline, the report's losses and the coverage agree; and a
``TrajectoryFinal`` with the estimate's poses inside the processed frames' time span,
exactly as the file gives them (not resampled at the frames). A frame without a pose in a
gap too short to be lost stays ``ok`` (a dropped pose), before the first pose
``initialising``.

An RTAB-Map database (``rtabmap.db``) replays as more than a trajectory: each node is a
keyframe at its frame with its map id and its update's statistics (odometry inliers and
features, local map size, the highest loop hypothesis), its links are graph edges (neighbour
links as odometry, global loop closures by appearance, local space links by proximity, a
rejected hypothesis as a rejected edge: :mod:`.rtabmap_graph`), and where tracking resumes
on a node that starts a new map, the recovery says so (RTAB-Map starts a map after its
odometry was reset or, in its dataset tool, lost).
"""

from pathlib import Path

import numpy as np
from pydantic import Field

from ..dataset.frame import Frame, Sequence, select_frames
from ..errors import InputError
from ..evaluation.coverage import coverage, median_period
from ..geometry.association import associate
from ..geometry.camera import Camera
from ..geometry.trajectory_formats import read_estimate
from ..pipelines.base import RUN_NAME, Pipeline
from ..pipelines.edges import EdgeClassifier
from ..pipelines.events import Event, FrameTracked, TrackingLost, TrackingRecovered, TrackingStatus, TrajectoryFinal
from ..pipelines.params import PipelineParams
from .rtabmap_graph import edges_by_node, graph_events, node_metrics

ASSOCIATION_MAX_DIFFERENCE_S = 0.02


class EstimateParams(PipelineParams):
    """What a report records as an estimate's parameters; set by the replay, never by ``--param``."""

    file: str = Field("", description="the trajectory file")
    format: str = Field("", description="its format ('': detected)")


def no_pose_reason(file: Path, gap_s: float) -> str:
    """Why an estimate is lost: its file has no pose for ``gap_s`` seconds."""
    return f"no pose in {file.name} for {gap_s:.2f} s"


def parse_estimate(text: str) -> tuple[str, Path]:
    """``NAME=FILE`` (the ``--estimate`` option) as the run's name and the file."""
    name, sep, file = text.partition("=")
    if not sep or not name.strip() or not file.strip():
        raise InputError(f"--estimate {text!r}: expected NAME=FILE, e.g. orbslam3=CameraTrajectory.txt")
    return name.strip(), Path(file.strip())


def named_estimates(texts: list[str], pipelines: list[str]) -> list[tuple[str, Path]]:
    """The ``--estimate NAME=FILE`` options as (name, file); every name must be unique among them and ``pipelines``."""
    named = [parse_estimate(text) for text in texts]
    taken = set(pipelines)
    for name, file in named:
        if not RUN_NAME.fullmatch(name):
            raise InputError(
                f"--estimate {name}={file}: a name holds letters, digits, '_', '-' and '.' only "
                f"(it names entities and files)"
            )
        if name in taken:
            kind = "a pipeline" if name in pipelines else "another estimate"
            raise InputError(f"--estimate {name}={file}: the name {name!r} is already {kind}'s; choose another")
        taken.add(name)
    return named


class EstimateReplay(Pipeline):
    """The events of an estimate over the frames at ``frame_stamps`` (the ones the run processes).

    ``sequence_stamps`` are all the sequence's frame stamps: a KITTI file has one pose per
    frame of the sequence. ``camera`` is the sequence's, which the estimate's poses are of.
    """

    name = "estimate"
    source = "estimate"
    Params = EstimateParams
    params: EstimateParams

    def __init__(self, params: EstimateParams, camera: Camera, sequence_stamps: np.ndarray, frame_stamps: np.ndarray):
        super().__init__(camera=camera, params=params)
        estimate, detected, self.database = read_estimate(Path(params.file), params.format or None, sequence_stamps)
        self.params = EstimateParams(file=params.file, format=detected)
        inside = (estimate.timestamps >= frame_stamps[0] - ASSOCIATION_MAX_DIFFERENCE_S) & (
            estimate.timestamps <= frame_stamps[-1] + ASSOCIATION_MAX_DIFFERENCE_S
        )
        self.trajectory = estimate.subset(inside)
        self._nodes = [node for node, kept in zip(self.database.nodes, inside) if kept] if self.database else []
        frame_rows, pose_rows = associate(frame_stamps, self.trajectory.timestamps, 0.0, ASSOCIATION_MAX_DIFFERENCE_S)
        self._pose_at = dict(zip(np.asarray(frame_stamps)[frame_rows].tolist(), pose_rows.tolist()))
        span = (float(frame_stamps[0]), float(frame_stamps[-1]))
        self._lost_intervals = coverage(
            span, self.trajectory.timestamps, median_period(frame_stamps), resumptions=self.trajectory.resumptions
        ).lost_intervals
        self._edges = EdgeClassifier()
        self._node_edges = edges_by_node(self.database) if self.database else {}
        self._frame_stamps = np.asarray(frame_stamps)
        self._frame_indices: list[int] = []
        self._state: TrackingStatus | None = None

    def process(self, frame: Frame) -> list[Event]:
        self._frame_indices.append(frame.index)
        row = self._pose_at.get(frame.timestamp)
        events: list[Event] = []
        if row is not None:
            state = TrackingStatus.OK
        elif any(start <= frame.timestamp <= end for start, end in self._lost_intervals):
            state = TrackingStatus.LOST
        else:
            state = (
                TrackingStatus.INITIALISING if self._state in (None, TrackingStatus.INITIALISING) else TrackingStatus.OK
            )
        if state is TrackingStatus.LOST and self._state is not TrackingStatus.LOST:
            events.append(
                TrackingLost(
                    frame.index, frame.timestamp, no_pose_reason(Path(self.params.file), self._gap_at(frame.timestamp))
                )
            )
        elif state is TrackingStatus.OK and self._state is TrackingStatus.LOST:
            events.append(TrackingRecovered(frame.index, frame.timestamp, "the estimate has poses again"))
        self._state = state
        if row is not None and self._nodes:
            return self._node_events(frame, row, events)
        pose = None if row is None else self.trajectory.poses[row]
        return [FrameTracked(frame.index, frame.timestamp, pose, state), *events]

    def _node_events(self, frame: Frame, row: int, events: list[Event]) -> list[Event]:
        """A database node's frame: its statistics, the node as a keyframe and its edges; a new
        map says so where tracking resumes."""
        node, pose = self._nodes[row], self.trajectory.poses[row]
        if node.stamp in self.trajectory.resumptions:
            reason = f"new map {node.map_id} in {Path(self.params.file).name}"
            events = [
                TrackingRecovered(event.frame_index, event.timestamp, reason)
                if isinstance(event, TrackingRecovered)
                else event
                for event in events
            ]
        stats = node.statistics
        tracked = FrameTracked(
            frame.index,
            frame.timestamp,
            pose,
            TrackingStatus.OK,
            features=int(stats.get("Odometry/Features/", 0)),
            inliers=int(stats.get("Odometry/Inliers/", 0)),
            keyframe_id=node.id,
            metrics=node_metrics(node),
        )
        return [
            tracked,
            *events,
            *graph_events(node, self._node_edges[node.id], frame.index, frame.timestamp, pose, self._edges),
        ]

    def finish(self) -> list[Event]:
        """The estimate's poses in the span of the frames seen, each placed at its nearest frame."""
        seen = self._frame_stamps[: len(self._frame_indices)]
        if len(seen) == 0:
            return [TrajectoryFinal(np.zeros(0, dtype=int), np.zeros(0), np.zeros((0, 4, 4)))]
        kept = self.trajectory.subset(self.trajectory.timestamps <= seen[-1] + ASSOCIATION_MAX_DIFFERENCE_S)
        after = np.clip(np.searchsorted(seen, kept.timestamps), 0, len(seen) - 1)
        before = np.maximum(after - 1, 0)
        nearest = np.where(kept.timestamps - seen[before] <= seen[after] - kept.timestamps, before, after)
        return [
            TrajectoryFinal(
                np.asarray(self._frame_indices, dtype=int)[nearest],
                kept.timestamps,
                kept.poses,
                resumptions=kept.resumptions,
            )
        ]

    def _gap_at(self, stamp: float) -> float:
        return next(end - start for start, end in self._lost_intervals if start <= stamp <= end)


def estimate_replay(
    sequence: Sequence, path: Path, format: str | None = None, *, max_frames: int | None = None, stride: int = 1
) -> EstimateReplay:
    """The replay of the estimate in ``path`` over the frames ``sequence`` yields with ``max_frames`` and
    ``stride``; reading it checks the file (an :class:`InputError` naming it) and settles its format."""
    stamps = np.asarray(sequence.timestamps, dtype=np.float64)
    processed = stamps[select_frames(len(stamps), max_frames, stride)]
    return EstimateReplay(EstimateParams(file=str(path), format=format or ""), sequence.camera, stamps, processed)
