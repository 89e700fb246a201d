"""Finished task results, kept so that a re-run skips work whose inputs have not changed.

A result is filed under a hash of everything that determines it: the sequence's content,
the pipeline (and the module implementing it) or the estimate file's bytes and format, its
parameters, seed and frame limit, and
the viewslam version and source code (so a development tree never serves results of code
it no longer has). Only successful results are kept; failures are retried.
"""

import hashlib
import json
from functools import cache
from pathlib import Path

from ..cache import cache_dir
from ..pipelines.base import pipeline_class
from ..version import __version__
from .runner import BenchmarkTask, TaskResult, task_seed

# Files whose bytes define a TUM sequence; images are represented by their names and sizes.
_DEFINING_FILES = ("rgb.txt", "depth.txt", "groundtruth.txt", "camera.json", "scenario.json")


def sequence_fingerprint(folder: Path) -> str:
    """Hash of the listing/groundtruth/calibration files' bytes and every file's path and size.

    Cheap on full-size sequences (no image is read) yet changes when an image is replaced
    by one of another size, re-encoded or truncated.
    """
    digest = hashlib.sha256()
    for name in _DEFINING_FILES:
        path = folder / name
        if path.is_file():
            digest.update(name.encode() + b"\0" + path.read_bytes() + b"\0")
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        digest.update(f"{path.relative_to(folder).as_posix()}\0{path.stat().st_size}\0".encode())
    return digest.hexdigest()


@cache
def code_fingerprint() -> str:
    """Hash of every Python source file of the installed viewer_slam package."""
    package = Path(__file__).resolve().parent.parent
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*.py")):
        digest.update(path.relative_to(package).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


def _file_digest(path: Path) -> str | None:
    """Hash of an estimate file's bytes (None when unreadable: the task will fail and not be stored)."""
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError:
        return None


def _parameters(task: BenchmarkTask) -> dict:
    """The task's complete parameter set under its external keys (an estimate has none): a task
    given the defaults implicitly is the same task as one given them explicitly."""
    if task.estimate is not None:
        return {}
    return (task.params if task.params is not None else pipeline_class(task.pipeline).Params()).model_dump(
        by_alias=True
    )


class ResultCache:
    """Task results on disk, one JSON file per key, under ``cache_dir("benchmark")`` by default."""

    def __init__(self, root: Path | None = None):
        self.root = Path(root) if root is not None else cache_dir("benchmark")
        self.root.mkdir(parents=True, exist_ok=True)
        self._fingerprints: dict[Path, str] = {}

    def key(self, task: BenchmarkTask) -> str:
        folder = Path(task.sequence).resolve()
        if folder not in self._fingerprints:
            self._fingerprints[folder] = sequence_fingerprint(folder)
        identity = {
            "sequence": self._fingerprints[folder],
            "pipeline": task.pipeline,
            "module": task.pipeline_modules.get(task.pipeline),
            "parameters": _parameters(task),
            "seed": task.seed,
            "max_frames": task.max_frames,
            "estimate": _file_digest(task.estimate) if task.estimate is not None else None,
            "estimate_format": task.estimate_format,
            "viewslam": __version__,
            "code": code_fingerprint(),
        }
        return hashlib.sha256(json.dumps(identity, sort_keys=True, default=str).encode()).hexdigest()

    def _path(self, task: BenchmarkTask) -> Path:
        return self.root / f"{self.key(task)}.json"

    def load(self, task: BenchmarkTask) -> TaskResult | None:
        """The stored result, relabelled for ``task``; None when absent, unreadable or its recording is missing."""
        if task.recording is not None and not Path(task.recording).is_file():
            return None
        try:
            stored = TaskResult.from_json(json.loads(self._path(task).read_text()))
        except (OSError, ValueError, TypeError):
            return None
        stored.sequence, stored.pipeline, stored.cached = task.name, task.pipeline, True
        stored.trial, stored.seed = task.trial, task_seed(task)  # one seed may be another benchmark's other trial
        return stored

    def store(self, task: BenchmarkTask, result: TaskResult) -> None:
        if not result.ok:
            return
        path = self._path(task)
        scratch = path.with_suffix(".tmp")
        scratch.write_text(json.dumps(result.to_json(), sort_keys=True))
        scratch.replace(path)
