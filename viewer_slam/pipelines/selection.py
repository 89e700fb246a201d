"""Which pipelines a command runs: the `--pipeline` option, read the same way by every command."""

from ..errors import InputError
from .base import PIPELINE_MODULES

BOTH = "both"
BUILT_IN = ("rgbdslam", "rtabmap")


def select_pipelines(choice: str) -> list[str]:
    """Names from a comma-separated ``choice``, in order, without repeats; ``both`` stands for the
    two built-in pipelines."""
    names: list[str] = []
    for name in (part.strip() for part in choice.split(",")):
        names += list(BUILT_IN) if name == BOTH else [name] if name else []
    unknown = [name for name in names if name not in PIPELINE_MODULES]
    if not names or unknown:
        raise InputError(f"--pipeline {choice!r}: valid pipelines are {', '.join([*PIPELINE_MODULES, BOTH])}")
    return list(dict.fromkeys(names))
