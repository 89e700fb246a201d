"""A one-page picture of an evaluation: the aligned trajectories and the errors over time."""

from dataclasses import dataclass
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (the backend must be chosen first)
from matplotlib.backend_bases import FigureCanvasBase  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

from .. import palette  # noqa: E402
from ..errors import InputError  # noqa: E402
from ..geometry.trajectory import Trajectory  # noqa: E402
from .coverage import lost_gap_threshold  # noqa: E402
from .evaluation import Evaluation  # noqa: E402

# Metadata that differs from run to run (a date, the writer's version), left out so the same
# evaluation gives the same file.
VOLATILE_METADATA = {"png": {"Software": None}, "svg": {"Date": None}, "pdf": {"CreationDate": None}}


@dataclass
class Scored:
    """One estimate in the picture: its legend label, its poses and its scores."""

    label: str
    estimate: Trajectory
    evaluation: Evaluation


def check_plot_path(path: Path) -> None:
    """:class:`InputError` naming ``--plot`` unless its extension is a format matplotlib writes."""
    formats = FigureCanvasBase.get_supported_filetypes()
    extension = path.suffix.lower().lstrip(".")
    if extension not in formats:
        problem = f"unsupported file extension {path.suffix!r}" if extension else "no file extension"
        raise InputError(f"--plot {path}: {problem} (use one of {', '.join(sorted(formats))})")


def estimate_color(label: str, position: int) -> str:
    """The run's colour in the viewer and the terminal (see :mod:`viewer_slam.palette`)."""
    return palette.run_colour(label, position).hex


def plot_evaluation(path: Path, groundtruth: Trajectory, scored: list[Scored], format: str | None = None) -> None:
    """Write the picture: top view (x-y) of groundtruth and every aligned estimate, and their errors over time.

    Each estimate has one colour (the top view's legend), each metric one line style (the
    error plot's legend): ATE solid, segment-aligned ATE dotted, penalised ATE dashed, lost
    time shaded. Lines break where an estimate has no pose for longer than the lost-gap
    threshold, so a jump never looks like motion. ``format`` (png, svg, pdf, ...) defaults to
    the extension of ``path``.
    """
    figure, (top, errors) = plt.subplots(1, 2, figsize=(12, 5), layout="constrained")
    top.plot(groundtruth.positions[:, 0], groundtruth.positions[:, 1], color=palette.GROUNDTRUTH.hex,
             label="groundtruth")
    origin = groundtruth.timestamps[0]  # the error plot's x axis is groundtruth time from its first pose
    for position, item in enumerate(scored):
        color, evaluation = estimate_color(item.label, position), item.evaluation
        gap = lost_gap_threshold(item.estimate.timestamps)
        aligned = evaluation.aligned_positions(item.estimate)
        if aligned is not None:
            top.plot(*_broken(item.estimate.timestamps, aligned[:, :2], gap).T[1:], color=color,
                     label=f"{item.label} ({evaluation.alignment_name})")
        for start, end in evaluation.coverage.lost_intervals:
            errors.axvspan(start - origin, end - origin, color=color, alpha=0.12)
        for series, style in ((evaluation.penalized_ate, "--"), (evaluation.segment_ate, ":"), (evaluation.ate, "-")):
            if series is not None:
                stamps, values = _broken(series.timestamps + evaluation.offset, series.errors[:, None], gap).T
                errors.plot(stamps - origin, values, color=color, linestyle=style, linewidth=1.0)
    top.set(title="Top view", xlabel="x [m]", ylabel="y [m]", aspect="equal")
    top.legend(loc="best", fontsize="small")
    alignment = scored[0].evaluation.alignment_name if scored else "rigid"
    styles = [Line2D([], [], color="0.2", linestyle="-", label=f"ATE ({alignment})"),
              Line2D([], [], color="0.2", linestyle=":", label="ATE, each segment aligned"),
              Line2D([], [], color="0.2", linestyle="--", label="penalised ATE"),
              Patch(color="0.2", alpha=0.12, label="lost")]
    errors.set(title="Error over time", xlabel="groundtruth time [s]", ylabel="error [m]")
    errors.set_xlim(0, groundtruth.timestamps[-1] - origin)
    errors.legend(handles=styles, loc="best", fontsize="small")
    format = format or path.suffix.lstrip(".").lower()
    with plt.rc_context({"svg.hashsalt": "viewslam"}):  # SVG element ids from a fixed salt, not a random one
        figure.savefig(path, format=format, dpi=100, metadata=VOLATILE_METADATA.get(format, {}))
    plt.close(figure)


def _broken(stamps: np.ndarray, values: np.ndarray, gap: float) -> np.ndarray:
    """Rows ``(stamp, *values)`` with a NaN row wherever consecutive stamps are ``gap`` apart."""
    rows = np.column_stack([stamps, values])
    breaks = np.flatnonzero(np.diff(stamps) > gap) + 1
    return np.insert(rows, breaks, np.nan, axis=0)
