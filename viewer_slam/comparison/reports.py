"""Read a `viewslam record` report with the trajectories written beside it, refusing what is not one.

``NAME.json`` holds one block per run; ``NAME.<run>.txt`` beside it holds that run's
trajectory (TUM format). A benchmark's block of a pair run as trials also lists every
trial's scores (``trials``). A report without the blocks a comparison reads (an older
version's, or `evaluate --json` output) is refused in one line.
"""

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..geometry.trajectory import Trajectory, read_tum

RUN_KEYS = ("frames_with_pose", "ate", "rpe", "coverage", "penalized_ate", "tracking_lost", "parameters")
"""What every run block of a report must hold to be compared."""


@dataclass
class RecordedRun:
    name: str
    block: dict[str, Any]
    trajectory: Trajectory


@dataclass
class RecordReport:
    path: Path
    sequence: dict[str, Any]
    runs: dict[str, RecordedRun]


def load_report(path: Path) -> RecordReport:
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise InputError.at(path, "no such report") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise InputError.at(path, f"cannot read the report: {error}") from None
    sequence, blocks = (data.get("sequence"), data.get("pipelines")) if isinstance(data, dict) else (None, None)
    if not isinstance(sequence, dict) or "name" not in sequence or not isinstance(blocks, dict) or not blocks:
        raise InputError.at(path, "not a `viewslam record` report (no sequence and pipelines blocks)")
    runs = {}
    for name, block in blocks.items():
        if not isinstance(block, dict):
            raise InputError.at(path, f"run {name!r} is {type(block).__name__}, not a run block")
        missing = [key for key in RUN_KEYS if key not in block]
        if missing:
            raise InputError.at(path, f"report of an older or unknown format: run {name!r} has no "
                                      f"{', '.join(missing)}; record it again with this version")
        problem = _shape_problem(block)
        if problem is not None:
            raise InputError.at(path, f"run {name!r}: {problem}")
        trajectory_path = path.with_name(f"{path.stem}.{name}.txt")
        if not trajectory_path.is_file():
            raise InputError.at(trajectory_path, f"no trajectory of run {name!r} beside {path.name}")
        runs[name] = RecordedRun(name, block, _trajectory(trajectory_path))
    return RecordReport(path, sequence, runs)


def _shape_problem(block: dict[str, Any]) -> str | None:
    """What in a run block is not of the shape a comparison reads, or None (the metric blocks are
    read as they come: a missing figure shows as one)."""
    if not isinstance(block["parameters"], dict):
        return "parameters is not an object"
    losses = block["tracking_lost"]
    if not isinstance(losses, list) or not all(isinstance(loss, dict) and isinstance(loss.get("frame"), int)
                                               and not isinstance(loss["frame"], bool) for loss in losses):
        return "tracking_lost is not a list of losses, each with its frame number"
    trials = block.get("trials", [])
    if not isinstance(trials, list) or not all(isinstance(trial, dict) and "status" in trial for trial in trials):
        return "trials is not a list of trials, each with its status"
    return None


def _trajectory(path: Path) -> Trajectory:
    """The run's poses; a run that never had one left an empty file."""
    if not path.read_text().strip():
        return Trajectory.empty()
    return read_tum(path)
