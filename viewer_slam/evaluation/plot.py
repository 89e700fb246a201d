"""A one-page picture of an evaluation: the aligned trajectories and the error over time."""

from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (the backend must be chosen first)

from .. import palette  # noqa: E402
from ..geometry.se3 import transform_points  # noqa: E402
from ..geometry.trajectory import Trajectory  # noqa: E402
from .coverage import lost_gap_threshold  # noqa: E402
from .evaluation import Evaluation  # noqa: E402

ESTIMATE = palette.run_colour("estimate")  # a run with no pipeline's name: the first fallback


def plot_evaluation(path: Path, groundtruth: Trajectory, estimate: Trajectory, evaluation: Evaluation) -> None:
    """Write a PNG: top view (x-y) of both trajectories, and the errors over time.

    Lines break where the estimate has no pose for longer than the lost-gap threshold, so
    a jump never looks like motion; lost time is shaded and its penalty drawn dashed.
    """
    figure, (top, errors) = plt.subplots(1, 2, figsize=(12, 5), layout="constrained")
    gap = lost_gap_threshold(estimate.timestamps)
    top.plot(groundtruth.positions[:, 0], groundtruth.positions[:, 1], color=palette.GROUNDTRUTH.hex,
             label="groundtruth")
    if evaluation.alignment is not None:
        aligned = transform_points(evaluation.alignment, estimate.positions)
        top.plot(*_broken(estimate.timestamps, aligned[:, :2], gap).T[1:], color=ESTIMATE.hex,
                 label="estimate (aligned)")
    top.set(title="Top view", xlabel="x [m]", ylabel="y [m]", aspect="equal")
    top.legend(loc="best")

    origin = groundtruth.timestamps[0]  # the x axis is groundtruth time from its first pose
    for number, (start, end) in enumerate(evaluation.coverage.lost_intervals):
        errors.axvspan(start - origin, end - origin, color=palette.LOST.hex, alpha=0.15,
                       label="lost" if number == 0 else None)
    for series, style in ((evaluation.penalized_ate,
                           {"color": palette.LOST.hex, "linestyle": "--", "label": "penalised ATE"}),
                          (evaluation.ate, {"color": ESTIMATE.hex, "label": "ATE"})):
        if series is not None:
            stamps, values = _broken(series.timestamps + evaluation.offset, series.errors[:, None], gap).T
            errors.plot(stamps - origin, values, linewidth=1.0, **style)
    errors.set(title=f"Error over time (coverage {evaluation.coverage.ratio:.1%})",
               xlabel="groundtruth time [s]", ylabel="error [m]")
    errors.set_xlim(0, groundtruth.timestamps[-1] - origin)
    errors.legend(loc="best")
    figure.savefig(path, dpi=100, metadata={"Software": None})
    plt.close(figure)


def _broken(stamps: np.ndarray, values: np.ndarray, gap: float) -> np.ndarray:
    """Rows ``(stamp, *values)`` with a NaN row wherever consecutive stamps are ``gap`` apart."""
    rows = np.column_stack([stamps, values])
    breaks = np.flatnonzero(np.diff(stamps) > gap) + 1
    return np.insert(rows, breaks, np.nan, axis=0)
