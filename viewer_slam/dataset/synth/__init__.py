"""Synthetic RGB-D sequences of the study's seven situations (and variants), with exact ground truth.

Each scenario mirrors a TUM RGB-D sequence (see ``docs/scenarios.md``) and is written as a
TUM folder with ``camera.json`` and ``scenario.json`` (covered intervals, loop, notes).
"""

from .generate import (GENERATOR_VERSION, SCENARIOS, STUDY_SCENARIOS, cached_scenario, default_frames,
                       generate_scenario, preview_frames, read_info)

__all__ = ["GENERATOR_VERSION", "SCENARIOS", "STUDY_SCENARIOS", "cached_scenario", "default_frames",
           "generate_scenario", "preview_frames", "read_info"]
