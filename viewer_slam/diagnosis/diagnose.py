"""A cause for every loss of a run: measure the window around it, classify, write it into the entry.

A loss is a ``tracking_lost[]`` entry (``frame``, ``timestamp``) of a run's report: a
pipeline's, a plugin's, or an estimate's replayed from a file (which loses tracking where
its poses stop).
"""

import math
from typing import Any

import numpy as np

from ..geometry.trajectory import Trajectory
from ..pipelines.run import PipelineRun
from .causes import Cause, DiagnosisThresholds, LossSignals, classify
from .signals import FrameSignals, SignalRecorder, groundtruth_motion


def diagnose_losses(
    name: str,
    losses: list[dict[str, Any]],
    signals: FrameSignals,
    tracking_minimum: int | None,
    groundtruth: Trajectory | None,
    thresholds: DiagnosisThresholds = DiagnosisThresholds(),
) -> list[dict[str, Any]]:
    """``losses`` with ``cause``, ranked ``causes``, ``evidence`` and a one-line ``text`` added.

    ``tracking_minimum`` is the keypoints/inliers the run needs to track, as its pipeline's
    parameters declare it (:meth:`PipelineParams.tracking_minimum`); where they declare none
    (plugins, imported estimates), the thresholds' ``default_minimum``.
    """
    minimum = thresholds.default_minimum if tracking_minimum is None else tracking_minimum
    speed, rotation_rate = groundtruth_motion(groundtruth, signals.timestamps)
    start = signals.timestamps[0] if len(signals) else 0.0
    diagnosed = []
    for loss in losses:
        row = min(signals.position(loss["frame"]), len(signals) - 1)
        measured = loss_signals(signals, row, minimum, speed, rotation_rate, thresholds)
        findings = classify(measured, thresholds)
        top = findings[0]
        text = f"{name} lost at {loss['timestamp'] - start:.1f} s: {top.cause.value}"
        diagnosed.append(
            {
                **loss,
                "cause": top.cause.value,
                "causes": [f.cause.value for f in findings],
                "evidence": measured.evidence(),
                "text": text if top.cause is Cause.UNKNOWN else f"{text} ({top.text})",
            }
        )
    return diagnosed


def loss_signals(
    signals: FrameSignals,
    row: int,
    minimum: int,
    speed: np.ndarray,
    rotation_rate: np.ndarray,
    thresholds: DiagnosisThresholds,
) -> LossSignals:
    """Medians over the lost frames from ``row`` on (at most ``window_frames``, stopping at a pose).

    Motion is the peak over those frames and as many before them, as a multiple of the run's
    median; residuals are the median over the tracked frames before the loss.
    """
    window = thresholds.window_frames
    lost = _lost_rows(signals, row, window)
    before = slice(max(row - window, 0), row)
    around = slice(max(row - window, 0), lost[-1] + 1)

    def median(values: np.ndarray) -> float:
        finite = values[np.isfinite(values)]
        return float(np.median(finite)) if len(finite) else math.nan

    def peak(values: np.ndarray, floor: float) -> tuple[float, float]:
        finite = values[around][np.isfinite(values[around])]
        if not len(finite):
            return math.nan, math.nan
        reference = max(median(values), floor)
        return float(finite.max()), float(finite.max()) / reference

    top_speed, speed_ratio = peak(speed, thresholds.still_speed)
    top_rotation, rotation_ratio = peak(rotation_rate, thresholds.still_rotation_rate)
    return LossSignals(
        frames=len(lost),
        minimum=minimum,
        corners=median(signals.corners[lost]),
        color_std=median(signals.color_std[lost]),
        uniform_share=median(signals.uniform_share[lost]),
        valid_depth_share=median(signals.valid_depth_share[lost]),
        keypoints=median(signals.keypoints[lost]),
        matches=median(signals.matches[lost]),
        inliers=median(signals.inliers[lost]),
        dynamic_share=median(signals.dynamic_share[before][signals.tracked[before]]),
        speed=top_speed,
        speed_ratio=speed_ratio,
        rotation_rate=top_rotation,
        rotation_ratio=rotation_ratio,
    )


def _lost_rows(signals: FrameSignals, row: int, window: int) -> np.ndarray:
    """``row`` and the following rows without a pose, ``window`` at most (just ``row`` if it has one)."""
    rows = [row]
    while len(rows) < window and rows[-1] + 1 < len(signals) and not signals.tracked[rows[-1] + 1]:
        rows.append(rows[-1] + 1)
    return np.array(rows)


def diagnose_run(
    run: PipelineRun,
    recorder: SignalRecorder,
    groundtruth: Trajectory | None,
    thresholds: DiagnosisThresholds = DiagnosisThresholds(),
) -> FrameSignals:
    """Give every loss of ``run`` its cause (in ``run.tracking_lost``, which the report reads).

    ``recorder`` is the signal sink that saw the run's frames and events; its signals are
    returned for the recording.
    """
    signals = recorder.signals()
    run.tracking_lost = diagnose_losses(
        run.pipeline, run.tracking_lost, signals, run.tracking_minimum, groundtruth, thresholds
    )
    return signals
