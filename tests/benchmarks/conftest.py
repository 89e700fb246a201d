"""A scene small enough for a script's smoke test: the first frames of a textured synthetic scenario
(the first of its full-length run, so the camera moves as slowly as there: both pipelines track)."""

from pathlib import Path

import pytest

from viewer_slam.dataset import synth

FRAMES = 10
RESOLUTION = (320, 240)


@pytest.fixture(scope="session")
def tiny_scene() -> Path:
    return synth.cached_scenario("nostructure_texture_near_withloop", resolution=RESOLUTION, first=FRAMES)
