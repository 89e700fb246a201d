"""Read a `viewslam record` report with the trajectories written beside it, refusing what is not one.

``NAME.json`` holds one block per run; ``NAME.<run>.txt`` beside it holds that run's
trajectory (TUM format). A report without the blocks a comparison reads (an older
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
        missing = [key for key in RUN_KEYS if key not in block]
        if missing:
            raise InputError.at(path, f"report of an older or unknown format: run {name!r} has no "
                                      f"{', '.join(missing)}; record it again with this version")
        trajectory_path = path.with_name(f"{path.stem}.{name}.txt")
        if not trajectory_path.is_file():
            raise InputError.at(trajectory_path, f"no trajectory of run {name!r} beside {path.name}")
        runs[name] = RecordedRun(name, block, _trajectory(trajectory_path))
    return RecordReport(path, sequence, runs)


def _trajectory(path: Path) -> Trajectory:
    """The run's poses; a run that never had one left an empty file."""
    if not path.read_text().strip():
        return Trajectory.empty()
    return read_tum(path)
