"""Pipeline classes that a plugin entry point may name but that are no valid pipeline."""

from benchmark_fake_pipeline import FakeParams, FakePipeline
from pydantic import Field, model_validator

from viewer_slam.pipelines.base import Pipeline
from viewer_slam.pipelines.params import PipelineParams


class HalfPipeline(Pipeline):
    """Tracks frames but never finishes."""

    Params = FakeParams

    def process(self, frame):
        return []


class UnparametrisedPipeline(FakePipeline):
    Params = dict


class NoDefaultParams(PipelineParams):
    wobble_m: float = Field(0.0, ge=0, description="noise")
    window: int = Field(alias="Odom/Window", ge=1, description="frames; no default")


class NoDefaultPipeline(FakePipeline):
    Params = NoDefaultParams


class DefaultOutOfBoundsParams(PipelineParams):
    window: int = Field(-1, ge=1, description="a default its own bound refuses")


class DefaultOutOfBoundsPipeline(FakePipeline):
    Params = DefaultOutOfBoundsParams


class RaisingDefaultsParams(PipelineParams):
    window: int = Field(3, description="frames")

    @model_validator(mode="after")
    def _never(self):
        raise ZeroDivisionError("a bug in the plugin's own rule")


class RaisingDefaultsPipeline(FakePipeline):
    Params = RaisingDefaultsParams
