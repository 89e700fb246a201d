"""A one-page picture of an evaluation: the aligned trajectories and the errors over time."""

from dataclasses import dataclass
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (the backend must be chosen first)
from matplotlib.backend_bases import FigureCanvasBase  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

from .. import palette  # noqa: E402
from ..errors import InputError  # noqa: E402
from ..geometry.trajectory import Trajectory  # noqa: E402
from .alignment import Alignment  # noqa: E402
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
    """Write :func:`draw_evaluation`'s picture; ``format`` (png, svg, pdf, ...) defaults to the
    extension of ``path``."""
    figure = draw_evaluation(groundtruth, scored)
    format = format or path.suffix.lstrip(".").lower()
    with plt.rc_context({"svg.hashsalt": "viewslam"}):  # SVG element ids from a fixed salt, not a random one
        figure.savefig(path, format=format, dpi=100, metadata=VOLATILE_METADATA.get(format, {}))
    plt.close(figure)


def draw_evaluation(groundtruth: Trajectory, scored: list[Scored]) -> Figure:
    """The picture: top view (x-y) of groundtruth and every aligned estimate, and beside it one
    panel per error series over time (ATE, segment-aligned ATE, penalised ATE).

    Each estimate has one colour throughout. The series get panels of their own rather than
    line styles in one plot: where an estimate never lost track the three coincide, and
    solid, dotted and dashed lines on top of one another read as one hatched line. Lost
    time is shaded in the estimate's colour on every panel. Lines break where an estimate
    has no pose for longer than the lost-gap threshold, so a jump never looks like motion.
    The legend, below the panels, names only what is drawn.
    """
    alignment = scored[0].evaluation.alignment_name if scored else Alignment.RIGID
    panels = [
        (title, attribute)
        for title, attribute in (
            (f"ATE ({alignment} alignment)", "ate"),
            ("ATE, each tracked segment aligned on its own", "segment_ate"),
            ("penalised ATE (while lost, the last pose is held)", "penalized_ate"),
        )
        if any(getattr(item.evaluation, attribute) is not None for item in scored)
    ]
    rows = max(len(panels), 1)
    figure = plt.figure(figsize=(12, 2.2 + 1.6 * rows), layout="constrained")
    grid = figure.add_gridspec(rows, 2, width_ratios=(1, 1.35))
    top = figure.add_subplot(grid[:, 0])
    errors = [figure.add_subplot(grid[0, 1])]
    errors += [figure.add_subplot(grid[row, 1], sharex=errors[0]) for row in range(1, rows)]
    top.plot(
        groundtruth.positions[:, 0], groundtruth.positions[:, 1], color=palette.GROUNDTRUTH.hex, label="groundtruth"
    )
    origin = groundtruth.timestamps[0]  # the error plot's x axis is groundtruth time from its first pose
    lost = False
    for position, item in enumerate(scored):
        color, evaluation = estimate_color(item.label, position), item.evaluation
        gap = lost_gap_threshold(item.estimate.timestamps)
        aligned = evaluation.aligned_positions(item.estimate)
        if aligned is not None:
            top.plot(
                *_broken(item.estimate.timestamps, aligned[:, :2], gap).T[1:],
                color=color,
                label=f"{item.label} ({evaluation.alignment_name})",
            )
        for axes, (_, attribute) in zip(errors, panels):
            for start, end in evaluation.coverage.lost_intervals:
                axes.axvspan(start - origin, end - origin, color=color, alpha=0.12, linewidth=0)
                lost = True
            series = getattr(evaluation, attribute)
            if series is not None:
                stamps, values = _broken(series.timestamps + evaluation.offset, series.errors[:, None], gap).T
                axes.plot(stamps - origin, values, color=color, linewidth=1.0)
    top.set(title="Top view", xlabel="x [m]", ylabel="y [m]")
    top.set_aspect("equal", adjustable="datalim")
    for axes, (title, _) in zip(errors, panels):
        axes.set_title(title, fontsize="medium", loc="left")
        axes.set_ylabel("error [m]")
        axes.set_ylim(bottom=0)
        axes.grid(alpha=0.3)
    for axes in errors[:-1]:
        axes.tick_params(labelbottom=False)  # one time axis, under the last panel
    errors[-1].set_xlabel("groundtruth time [s]")
    errors[-1].set_xlim(0, groundtruth.timestamps[-1] - origin)
    handles, labels = top.get_legend_handles_labels()
    if lost:
        handles.append(Patch(color="0.2", alpha=0.12, label="lost (shaded in the estimate's colour)"))
    figure.legend(
        handles=handles, loc="outside lower center", ncols=min(len(handles), 3), fontsize="small", frameon=False
    )
    return figure


def _broken(stamps: np.ndarray, values: np.ndarray, gap: float) -> np.ndarray:
    """Rows ``(stamp, *values)`` with a NaN row wherever consecutive stamps are ``gap`` apart."""
    rows = np.column_stack([stamps, values])
    breaks = np.flatnonzero(np.diff(stamps) > gap) + 1
    return np.insert(rows, breaks, np.nan, axis=0)
