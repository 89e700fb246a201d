"""Score a pipeline run against its sequence's groundtruth, over the frames it processed."""

from collections.abc import Sequence as Stamps

import numpy as np

from ..evaluation.coverage import Span
from ..evaluation.evaluation import Evaluation, evaluate
from ..evaluation.statistics import ErrorSeries
from ..geometry.trajectory import Trajectory
from ..pipelines.run import PipelineRun

PROCESSED_FRAMES_RULE = "processed frames"
MIN_NODE_PAIRS = 3  # a rigid alignment needs three poses


def evaluate_run(
    groundtruth: Trajectory | None, run: PipelineRun, frame_timestamps: Stamps[float] | np.ndarray
) -> tuple[Evaluation | None, Evaluation | None]:
    """The run's scores and its raw odometry's.

    Coverage spans the first to the last processed frame (a run given the first N frames
    is not charged for the rest), and a gap counts as lost in units of the processed
    frames' period, so a run with a few scattered poses is not mistaken for a tracked one.
    """
    if groundtruth is None or len(frame_timestamps) == 0:
        return None, None
    stamps = np.asarray(frame_timestamps, dtype=np.float64)
    span = Span(float(stamps[0]), float(stamps[-1]), PROCESSED_FRAMES_RULE)
    period = float(np.median(np.diff(stamps))) if len(stamps) > 1 else None
    scores = evaluate(groundtruth, run.trajectory, span=span, frame_period=period)
    scores.node_ate = node_ate(groundtruth, run)
    odometry = evaluate(groundtruth, run.odometry, span=span, frame_period=period) if run.odometry is not None else None
    return scores, odometry


def node_ate(groundtruth: Trajectory, run: PipelineRun) -> ErrorSeries | None:
    """ATE over the run's graph nodes alone, aligned on their own pairs: the final poses of
    the frames that became nodes (a node's frame pose is the node's optimised pose), what
    RTAB-Map's ``rtabmap-rgbd_dataset`` writes as its trajectory. None without nodes with a
    pose or with fewer than three pairs."""
    if not run.node_frames or run.trajectory is None or not len(run.trajectory):
        return None
    nodes = np.isin(run.frame_indices, np.unique(run.node_frames))
    if nodes.sum() < MIN_NODE_PAIRS:
        return None
    series = evaluate(groundtruth, run.trajectory.subset(nodes)).ate
    return series if series is not None and len(series.errors) >= MIN_NODE_PAIRS else None
