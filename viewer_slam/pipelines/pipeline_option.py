"""Which pipelines a command runs: the `--pipeline` option, read the same way by every command."""

from ..errors import InputError
from .base import pipeline_names

BOTH = "both"
BUILT_IN = ("rgbdslam", "rtabmap")


def select_pipelines(choice: str) -> list[str]:
    """Names from a comma-separated ``choice``, in order, without repeats; ``both`` stands for the
    two built-in pipelines, any other name for a built-in or plugin pipeline."""
    names: list[str] = []
    for name in (part.strip() for part in choice.split(",")):
        names += list(BUILT_IN) if name == BOTH else [name] if name else []
    known = pipeline_names()
    unknown = [name for name in names if name not in known]
    if not names or unknown:
        raise InputError(f"--pipeline {choice!r}: valid pipelines are {', '.join([*known, BOTH])}")
    return list(dict.fromkeys(names))
