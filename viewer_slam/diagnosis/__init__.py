"""Why a run lost tracking: per-frame signals, the causes they point to, and the loss entries' cause."""

from .causes import CAUSE_ORDER, Cause, DiagnosisThresholds, LossSignals, classify
from .diagnose import diagnose_losses, diagnose_run
from .signals import DYNAMIC_SHARE_METRIC, FrameSignals, ImageSignals, MeasuredImages, SignalRecorder, measure_image

__all__ = [
    "CAUSE_ORDER",
    "Cause",
    "DYNAMIC_SHARE_METRIC",
    "DiagnosisThresholds",
    "FrameSignals",
    "ImageSignals",
    "LossSignals",
    "MeasuredImages",
    "SignalRecorder",
    "classify",
    "diagnose_losses",
    "diagnose_run",
    "measure_image",
]
