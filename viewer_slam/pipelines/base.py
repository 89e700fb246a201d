"""The pipeline interface and the registry that builds pipelines by name."""

import importlib
from abc import ABC, abstractmethod
from typing import Any, ClassVar

from ..dataset.frame import Frame
from ..errors import InputError
from ..geometry.camera import Camera
from .events import Event

# Pipelines are imported on first use so that `viewslam evaluate` never pays for them.
PIPELINE_MODULES = {
    "rgbdslam": "viewer_slam.pipelines.rgbdslam",
    "rtabmap": "viewer_slam.pipelines.rtabmap",
}


class Pipeline(ABC):
    """Fed frames in order; returns the events each frame produced.

    ``seed`` drives every random choice (RANSAC, candidate sampling), so the same frames,
    parameters and seed give the same events.
    """

    name: ClassVar[str]
    Params: ClassVar[type]

    def __init__(self, camera: Camera, params: Any = None, seed: int = 0):
        self.camera = camera
        self.params = params if params is not None else self.Params()
        self.seed = seed

    @abstractmethod
    def process(self, frame: Frame) -> list[Event]:
        """Track one frame; the list always holds exactly one FrameTracked."""

    @abstractmethod
    def finish(self) -> list[Event]:
        """Final optimisation; the list ends with a TrajectoryFinal."""


def pipeline_class(name: str) -> type[Pipeline]:
    if name not in PIPELINE_MODULES:
        raise InputError(f"unknown pipeline {name!r}; valid: {', '.join(PIPELINE_MODULES)}")
    module = importlib.import_module(PIPELINE_MODULES[name])
    return module.PIPELINE


def make_pipeline(name: str, camera: Camera, params: Any = None, seed: int = 0) -> Pipeline:
    return pipeline_class(name)(camera, params, seed)
