"""Why tracking was lost: named causes, each tested against a named threshold on measured signals.

The classifier sees only numbers measured around the loss (:class:`LossSignals`), never
the sequence's name. Every cause that holds is returned with the numbers behind it, ranked
by :data:`CAUSE_ORDER`: a condition of the scene or sensor explains the tracker's symptoms,
so it ranks before them (a covered sensor also leaves too few features; the cover is why).
"""

import dataclasses
import math
from dataclasses import dataclass
from enum import Enum

from pydantic import BaseModel, ConfigDict, Field

from .signals import CORNER_CONTRAST


class Cause(str, Enum):
    SENSOR_BLOCKED = "sensor blocked"
    NO_DEPTH = "no depth"
    FAST_MOTION = "fast motion"
    DYNAMIC_SCENE = "dynamic scene"
    TOO_FEW_FEATURES = "too few features"
    TOO_FEW_INLIERS = "too few inliers"
    UNKNOWN = "unknown"


CAUSE_ORDER = tuple(Cause)
"""Rank of the causes that hold: scene and sensor conditions first, tracker symptoms last."""


class DiagnosisThresholds(BaseModel):
    """The thresholds of the causes, fixed before looking at any held-out data (docs/diagnosis.md).

    A threshold outside its bounds is refused when the thresholds are made.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    window_frames: int = Field(
        5,
        ge=1,
        description="lost frames examined from the loss on (and tracked frames before it, for motion and residuals)",
    )
    blocked_uniform_share: float = Field(
        0.9, ge=0.0, le=1.0, description="share of near-median pixels above which the colour image is near uniform"
    )
    blocked_depth_share: float = Field(
        0.1, ge=0.0, le=1.0, description="valid depth share at or below which a near-uniform frame is a blocked sensor"
    )
    min_depth_share: float = Field(0.25, ge=0.0, le=1.0, description="valid depth share below which there is no depth")
    fast_motion_ratio: float = Field(
        3.0,
        gt=1.0,
        description="groundtruth speed or rotation rate, as a multiple of the run's median, above which motion is fast",
    )
    still_speed: float = Field(0.05, gt=0.0, description="m/s; the median speed is taken as at least this")
    still_rotation_rate: float = Field(
        0.1, gt=0.0, description="rad/s; the median rotation rate is taken as at least this"
    )
    dynamic_share: float = Field(
        0.3,
        ge=0.0,
        le=1.0,
        description="share of matched points moving inconsistently with the camera above which the scene is dynamic",
    )
    default_minimum: int = Field(
        20,
        ge=1,
        description="keypoints/inliers needed when the run's pipeline declares "
        "no minimum (plugins, imported estimates)",
    )


_COUNTS = ("frames", "minimum", "corners", "keypoints", "matches", "inliers")


@dataclass(frozen=True)
class LossSignals:
    """Medians over the lost frames of the window (motion: maxima, as multiples of the run's median).

    NaN where a signal was not measured: tracker counts of an imported estimate, motion
    without groundtruth, ``dynamic_share`` of a pipeline that reports no residuals.
    """

    frames: int
    minimum: int
    corners: float
    color_std: float
    uniform_share: float
    valid_depth_share: float
    keypoints: float = math.nan
    matches: float = math.nan
    inliers: float = math.nan
    dynamic_share: float = math.nan
    speed: float = math.nan
    speed_ratio: float = math.nan
    rotation_rate: float = math.nan
    rotation_ratio: float = math.nan

    def evidence(self) -> dict[str, float | int]:
        """The measured numbers, rounded for reading (whole counts as integers); unmeasured ones left out."""
        values = {}
        for field in dataclasses.fields(self):
            value = round(float(getattr(self, field.name)), 3)
            if math.isnan(value):
                continue
            values[field.name] = int(value) if field.name in _COUNTS and value.is_integer() else value
        return values


@dataclass(frozen=True)
class Finding:
    cause: Cause
    text: str


def classify(signals: LossSignals, thresholds: DiagnosisThresholds = DiagnosisThresholds()) -> list[Finding]:
    """Every cause that holds, ranked by :data:`CAUSE_ORDER`; ``unknown`` alone when none does."""
    s, t, minimum = signals, thresholds, signals.minimum
    findings = []
    if s.uniform_share >= t.blocked_uniform_share and s.valid_depth_share <= t.blocked_depth_share:
        findings.append(
            Finding(
                Cause.SENSOR_BLOCKED, f"colour {s.uniform_share:.0%} uniform, {s.valid_depth_share:.0%} valid depth"
            )
        )
    if s.valid_depth_share < t.min_depth_share:
        findings.append(
            Finding(Cause.NO_DEPTH, f"{s.valid_depth_share:.0%} valid depth, minimum {t.min_depth_share:.0%}")
        )
    fast = _fast_motion(s, t)
    if fast:
        findings.append(Finding(Cause.FAST_MOTION, fast))
    if s.dynamic_share >= t.dynamic_share:
        findings.append(Finding(Cause.DYNAMIC_SCENE, f"{s.dynamic_share:.0%} of matched points moving"))
    if s.keypoints < minimum:
        findings.append(Finding(Cause.TOO_FEW_FEATURES, f"{s.keypoints:.0f} keypoints, minimum {minimum}"))
    elif s.corners < minimum:
        findings.append(
            Finding(Cause.TOO_FEW_FEATURES, f"{s.corners:.0f} corners of contrast {CORNER_CONTRAST}, minimum {minimum}")
        )
    elif s.inliers < minimum:  # NaN (not reported) compares false
        findings.append(
            Finding(Cause.TOO_FEW_INLIERS, f"{s.inliers:.0f} inliers of {s.matches:.0f} matches, minimum {minimum}")
        )
    if not findings:
        return [Finding(Cause.UNKNOWN, "nothing measured stands out")]
    return sorted(findings, key=lambda finding: CAUSE_ORDER.index(finding.cause))


def _fast_motion(s: LossSignals, t: DiagnosisThresholds) -> str:
    """The text of the faster of translation and rotation when either is fast, else ''."""
    candidates = []
    if s.speed_ratio >= t.fast_motion_ratio:
        candidates.append((s.speed_ratio, f"{s.speed:.2f} m/s, {s.speed_ratio:.1f}x the median"))
    if s.rotation_ratio >= t.fast_motion_ratio:
        candidates.append(
            (s.rotation_ratio, f"{math.degrees(s.rotation_rate):.0f} deg/s, {s.rotation_ratio:.1f}x the median")
        )
    return max(candidates)[1] if candidates else ""
