"""Pipeline classes that a plugin entry point may name but that are no valid pipeline."""

from benchmark_fake_pipeline import FakeParams, FakePipeline

from viewer_slam.pipelines.base import Pipeline


class HalfPipeline(Pipeline):
    """Tracks frames but never finishes."""

    Params = FakeParams

    def process(self, frame):
        return []


class UnparametrisedPipeline(FakePipeline):
    Params = dict
