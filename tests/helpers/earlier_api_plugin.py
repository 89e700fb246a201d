"""A plugin written against the parameter API before parameters were pydantic models."""

from dataclasses import dataclass

from viewer_slam.pipelines.params import param


@dataclass(frozen=True)
class StationaryParams:
    window: int = param(5, key="Odom/Window", help="frames", ge=1)
