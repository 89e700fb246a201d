"""The study: sequences x pipelines, run locally or on Ray, tabulated and charted."""

from ..commands import make_callable

make_callable(
    __name__, f"{__name__}.command", "benchmark"
)  # `viewer_slam.benchmark(...)` runs the command: see commands.py
