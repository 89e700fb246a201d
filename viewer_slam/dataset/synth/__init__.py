"""Synthetic RGB-D sequences of the study's seven situations (and variants), with exact ground truth.

Each scenario mirrors a TUM RGB-D sequence (see ``docs/scenarios.md``) and is written as a
TUM folder with ``camera.json`` and ``scenario.json`` (covered intervals, loop, notes).
The generator (renderer, OpenCV) loads on first use of one of its functions, so listing the
scenarios stays light.
"""

import importlib

from .catalog import SCENARIOS, STUDY_SCENARIOS

_GENERATOR = (
    "GENERATOR_VERSION",
    "cached_scenario",
    "default_frames",
    "generate_scenario",
    "preview_frames",
    "read_info",
)

__all__ = ["SCENARIOS", "STUDY_SCENARIOS", *_GENERATOR]


def __getattr__(name: str):
    if name in _GENERATOR:
        return getattr(importlib.import_module(".generate", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
