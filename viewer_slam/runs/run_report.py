"""The JSON report of a run: sequence, versions and one block per pipeline (docs/report-schema.md)."""

import json
import math
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from ..evaluation.evaluation import Evaluation
from ..evaluation.statistics import stats_or_none
from ..pipelines.run import PipelineRun

# Distribution names per component; the first one installed wins (OpenCV ships under several).
_DISTRIBUTIONS = {
    "viewslam": ("viewer-slam",),
    "rerun": ("rerun-sdk",),
    "opencv": ("opencv-contrib-python-headless", "opencv-contrib-python", "opencv-python-headless", "opencv-python"),
    "gtsam": ("gtsam",),
    "open3d": ("open3d", "open3d-cpu"),
}


def pipeline_report(
    run: PipelineRun, evaluation: Evaluation | None, odometry_evaluation: Evaluation | None
) -> dict[str, Any]:
    """One run's block; metric blocks are null without groundtruth (or without poses).

    The run's ``source`` says where its poses came from: ``"pipeline"``, or ``"estimate"`` (a
    trajectory file replayed; its parameters are the file and the format read)."""
    metrics = (
        evaluation.to_dict()
        if evaluation is not None
        else {
            "alignment": None,
            "ate": None,
            "ate_segments": None,
            "rpe": None,
            "coverage": None,
            "penalized_ate": None,
        }
    )
    return {
        "source": run.source,
        "frames_with_pose": len(run.trajectory),
        **metrics,
        "odometry_ate": stats_or_none(odometry_evaluation.ate) if odometry_evaluation is not None else None,
        "node_ate": stats_or_none(evaluation.node_ate) if evaluation is not None else None,
        "loop_closures": {"accepted": run.loop_closures_accepted, "rejected": run.loop_closures_rejected},
        "edges": dict(run.edges),
        "edges_by_detection": {name: dict(counts) for name, counts in sorted(run.edges_by_detection.items())},
        "keyframes": run.keyframes,
        "tracking_lost": run.tracking_lost,
        "timing": {"total_s": run.total_s, "fps": run.fps, "per_stage_ms": run.per_stage_ms},
        "parameters": run.parameters,
    }


def build_report(sequence, pipeline_blocks: dict[str, dict], interrupted: bool) -> dict[str, Any]:
    """The whole report for ``sequence`` (a TumSequence) and the pipelines' blocks."""
    return {
        "sequence": sequence_block(sequence),
        "interrupted": interrupted,
        "versions": versions(),
        "pipelines": pipeline_blocks,
    }


def sequence_block(sequence) -> dict[str, Any]:
    """What a report says of its sequence: name, folder, frames and duration."""
    return {
        "name": sequence.name,
        "path": str(sequence.path),
        "frames": len(sequence),
        "duration_s": sequence.duration_s,
    }


def versions() -> dict[str, str | None]:
    """Installed versions, read from package metadata so no heavy module is imported."""
    return {component: _installed_version(names) for component, names in _DISTRIBUTIONS.items()}


def write_report(path: Path, report: dict[str, Any]) -> None:
    """Write strict JSON: NaN and infinities become null, numpy scalars plain numbers."""
    Path(path).write_text(json.dumps(_json_safe(report), indent=2, allow_nan=False) + "\n")


def _installed_version(names: tuple[str, ...]) -> str | None:
    for name in names:
        try:
            return metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return None


def _json_safe(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(key): _json_safe(item) for key, item in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_json_safe(item) for item in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value
