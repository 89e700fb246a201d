"""What `viewslam record` is given beside the runs (the frames to read) and what it gives back."""

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..runs.service import ScoredRun


@dataclass(frozen=True)
class FrameSelection:
    """The frames a record reads: every ``stride``-th, at most ``max_frames`` of them (None: all)."""

    max_frames: int | None = None
    stride: int = 1


@dataclass(frozen=True)
class RecordResult:
    """What a record wrote (``written``, the files that exist) and the report it wrote; ``scored`` holds
    each run's scores for a caller that goes on with them (a benchmark task).
    """

    recording: Path
    report_path: Path
    trajectories: dict[str, Path]
    report: dict[str, Any]
    written: list[Path] = field(default_factory=list)
    scored: dict[str, ScoredRun] = field(default_factory=dict)

    @property
    def interrupted(self) -> bool:
        """Whether a stop request (Ctrl-C) or a failure mid-run cut the record short."""
        return bool(self.report["interrupted"])
