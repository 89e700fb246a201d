"""The layout a recording opens with: 3D scene and log left; matches, error plots and states right.

Plots carry no legend inside the curves: each view's title names what its colours are
(every run has one colour, :mod:`viewer_slam.palette`), and every error plot holds, per run,
a thick bar at zero across the frames where that run had no pose, so a plot and the
playhead agree where tracking was lost. Titles are short enough to show whole at 1280x800
(:mod:`.fit`).
"""

import numpy as np
import rerun as rr
import rerun.blueprint as rrb
from rerun.blueprint.api import EntityPathLike, VisualizerLike

from .. import palette
from ..pipelines.edges import EdgeKind
from . import layout
from .fit import LEFT_SHARE, RIGHT_SHARE, column_px, title_chars
from .sizes import MIN_EXTENT_M, extent

# The eye: a camera path of this extent or less is framed as one of this extent (a desk scene
# reaches beyond a camera that turns in place), looked at from behind and above.
EYE_MIN_EXTENT_M = 0.25
EYE_DISTANCE_SHARE = 1.25  # distance from the look target, as a multiple of the extent ...
EYE_DISTANCE_M = 0.45  # ... plus this: the depth an RGB-D camera sees beyond its path
EYE_ELEVATION_DEG = 35.0
# The whole path is kept inside a cone of this half-angle around the view axis (the viewer's
# vertical field of view is wider: a margin for the frustums and the window's aspect).
EYE_HALF_ANGLE_DEG = 20.0
# With nothing to see beyond the camera path (trajectory files alone), the path may fill more of the view.
PATH_ONLY_HALF_ANGLE_DEG = 26.0
LOOK_AHEAD_SHARE = 0.1  # the look target lies ahead of the path (towards the map it sees) ...
LOOK_AHEAD_M = 0.25  # ... by this share of the extent plus this
# A camera path whose mean viewing direction (horizontal) is shorter than this turns all around:
# no "ahead"; it is seen from a fixed side.
MIN_HEADING = 0.3
FALLBACK_DIRECTION = np.array([-0.45, -0.9, 0.0])  # from the eye towards the target, horizontal
LOST_BAND = "lost"  # the series that marks a run's frames without a pose on its error plots
LOST_BAND_WIDTH = 10.0  # the first run's; later runs' are narrower (lost_band_widths)
# Loop closures of the last second (on the frame timeline: the last 30 frames, TUM's rate) are
# drawn bright; older ones dim.
RECENT_LOOP_S = 1.0
RECENT_LOOP_FRAMES = 30


def _series(pipelines: list[str], series: str) -> list[str]:
    return [f"/{layout.metric(name, series)}" for name in pipelines]


def _horizontal_heading(poses: np.ndarray) -> np.ndarray | None:
    """The mean horizontal viewing direction of camera poses ``(N, 4, 4)`` (optical z axis),
    None when they look all around (or at the floor)."""
    forward = poses[:, :3, 2].mean(axis=0)
    forward[2] = 0.0
    norm = np.linalg.norm(forward)
    return forward / norm if norm >= MIN_HEADING else None


def overview_eye(groundtruth: np.ndarray, path_only: bool = False) -> rrb.EyeControls3D:
    """An orbital eye that frames the camera path and what the cameras see.

    ``groundtruth`` is poses ``(N, 4, 4)`` or positions ``(N, 3)``. With poses whose mean
    viewing direction is clear, the eye stands behind and above the path and looks over it
    to a target ahead of it, where the map is; otherwise it looks at the path's centre from
    a fixed side, from a distance that is a multiple of the path's extent (with a floor) or,
    if further, the one that keeps the whole path in view: a desk path of 12 cm and a 30 m
    hall open alike. ``path_only`` (no map, no images: trajectory files alone) looks at the
    path's centre from the fixed side, as close as keeps the path within
    PATH_ONLY_HALF_ANGLE_DEG of the view's axis.
    """
    groundtruth = np.asarray(groundtruth, dtype=np.float64)
    poses = groundtruth if groundtruth.ndim == 3 else None
    positions = groundtruth[:, :3, 3] if poses is not None else groundtruth.reshape(-1, 3)
    scene = max(extent(positions), EYE_MIN_EXTENT_M, MIN_EXTENT_M)
    centre = (positions.min(axis=0) + positions.max(axis=0)) / 2
    heading = _horizontal_heading(poses) if poses is not None else None
    if heading is None or path_only:
        heading, target = FALLBACK_DIRECTION / np.linalg.norm(FALLBACK_DIRECTION), centre
    else:
        target = centre + (LOOK_AHEAD_SHARE * scene + LOOK_AHEAD_M) * heading
    elevation = np.radians(EYE_ELEVATION_DEG)
    axis = np.cos(elevation) * heading - [0.0, 0.0, np.sin(elevation)]  # from the eye to the target
    offsets = positions - target
    along = offsets @ axis
    across = np.linalg.norm(offsets - along[:, None] * axis, axis=1)
    half_angle = np.radians(PATH_ONLY_HALF_ANGLE_DEG if path_only else EYE_HALF_ANGLE_DEG)
    framed = float(np.max(across / np.tan(half_angle) - along))
    distance = max(scene if path_only else EYE_DISTANCE_SHARE * scene + EYE_DISTANCE_M, framed)
    position = target - distance * axis
    return rrb.EyeControls3D(
        kind="Orbital", position=position, look_target=target, eye_up=[0.0, 0.0, 1.0], speed=max(scene, 0.5)
    )


def recent_window() -> rrb.VisibleTimeRanges:
    """The last RECENT_LOOP_S seconds up to the playhead, on whichever timeline is shown."""
    return rrb.VisibleTimeRanges(
        [
            rrb.VisibleTimeRange(
                "frame",
                start=rrb.TimeRangeBoundary.cursor_relative(seq=-RECENT_LOOP_FRAMES),
                end=rrb.TimeRangeBoundary.cursor_relative(),
            ),
            rrb.VisibleTimeRange(
                "time",
                start=rrb.TimeRangeBoundary.cursor_relative(seconds=-RECENT_LOOP_S),
                end=rrb.TimeRangeBoundary.cursor_relative(),
            ),
        ]
    )


def colour_legend(pipelines: list[str]) -> str:
    """``rgbdslam orange, rtabmap blue``: the runs' colours, for a view's title."""
    return ", ".join(f"{name} {palette.run_colour(name, i).name}" for i, name in enumerate(pipelines))


def hidden_legend() -> rrb.PlotLegend:
    """No legend over the curves: the title names the colours."""
    return rrb.PlotLegend(visible=False)


def lost_band_widths(count: int) -> list[float]:
    """Widths of the runs' lost bands, narrower for each later run: where several runs are lost
    at once, each band shows inside the one before."""
    return [LOST_BAND_WIDTH / (position + 1) for position in range(count)]


def lost_band_overrides(paths: list[str]) -> dict[EntityPathLike, VisualizerLike]:
    """The width of each lost band at ``paths`` (one per run, in the runs' order) in a plot."""
    return {
        path: rr.SeriesLines.from_fields(widths=[width]) for path, width in zip(paths, lost_band_widths(len(paths)))
    }


def whole_timeline() -> rrb.TimeAxis:
    """A time axis that spans all the data: the viewer's default, while it follows the playhead,
    is a window of a couple of thousand steps, a small part of a 100 Hz groundtruth's frames."""
    return rrb.TimeAxis(
        view_range=rrb.TimeRange(start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.infinite())
    )


# The error plots' titles (each followed by the runs' colours): short enough for the right column.
ERROR_PLOTS = {
    "ate": "ATE [m]",
    "ate_segments": "seg. ATE [m]",
    "rpe_trans": "RPE [m]",
    "rpe_rot": "RPE [deg]",
    "coverage": "coverage",
}


def error_plot(title: str, pipelines: list[str], series: str, axis_x: rrb.TimeAxis | None = None) -> rrb.TimeSeriesView:
    """One series of every run and the runs' lost bands, its colours named in the title."""
    bands = lost_band_overrides(_series(pipelines, LOST_BAND))
    return rrb.TimeSeriesView(
        name=f"{title} · {colour_legend(pipelines)} · bar: no pose",
        contents=_series(pipelines, series) + _series(pipelines, LOST_BAND),
        plot_legend=hidden_legend(),
        overrides=bands,
        axis_x=axis_x,
    )


def log_columns() -> rrb.archetypes.TextLogColumns:
    """Frame, level and text: each line starts with its run, so the entity path column is left out."""
    return rrb.archetypes.TextLogColumns(
        timeline_columns=[rrb.encodings.TimelineColumn("frame"), rrb.encodings.TimelineColumn("time", visible=False)],
        text_log_columns=[
            rrb.encodings.TextLogColumn("LogLevel"),
            rrb.encodings.TextLogColumn("Body"),
            rrb.encodings.TextLogColumn("EntityPath", visible=False),
        ],
    )


def scene_title(pipelines: list[str]) -> str:
    """The 3D view's colours: groundtruth, each run (dim while lost), loop closures (bright while recent)."""
    return (
        f"groundtruth {palette.GROUNDTRUTH.name} · {colour_legend(pipelines)}, dim when lost · "
        f"loops {palette.ACCEPTED.name}, bright {RECENT_LOOP_S:g} s"
    )


def matches_title(name: str, side_by_side: int) -> str:
    """A run's matches view: with the inlier and outlier colours where the title has the room
    (one of ``side_by_side`` views in the right column)."""
    full = f"{name}: matches (inliers {palette.INLIER.name}, outliers {palette.OUTLIER.name})"
    return full if len(full) <= title_chars(column_px(RIGHT_SHARE, side_by_side)) else f"{name} matches"


def default_blueprint(
    pipelines: list[str], groundtruth: np.ndarray | None = None, counted: list[str] | None = None
) -> rrb.Blueprint:
    """3D view of groundtruth and every pipeline; per pipeline its image with matches; the
    ATE of all pipelines in one plot, the other metrics in tabs, tracking state and log.

    ``groundtruth`` (poses ``(N, 4, 4)`` or positions ``(N, 3)``) places the 3D view's eye
    (:func:`overview_eye`). The features / inliers plot shows the ``counted`` runs
    (default: all; an imported estimate has no counts)."""
    counted = pipelines if counted is None else counted
    eye = overview_eye(groundtruth) if groundtruth is not None and len(groundtruth) else None
    # Keyframe depth clouds, the many rejected loop closures and the local edges (short chords
    # among recent keyframes) would bury the map and the trajectories; one click shows them.
    overrides: dict[EntityPathLike, VisualizerLike] = {
        f"/{path}": rrb.EntityBehavior(visible=False)
        for name in pipelines
        for path in (
            f"{layout.latest_keyframe(name)}/depth",
            layout.rejected_loop_closures(name),
            layout.edges(name, EdgeKind.LOCAL.value),
        )
    }
    overrides.update({f"/{layout.recent_loop_closures(name)}": recent_window() for name in pipelines})
    scene = rrb.Spatial3DView(origin="world", name=scene_title(pipelines), eye_controls=eye, overrides=overrides)
    matches = rrb.Horizontal(
        *[
            rrb.Spatial2DView(
                origin=layout.matches(name),
                contents=[f"/{layout.CAMERA_IMAGE}", "$origin/**"],
                name=matches_title(name, len(pipelines)),
            )
            for name in pipelines
        ]
    )
    ate = error_plot(ERROR_PLOTS["ate"], pipelines, "ate")
    details = rrb.Tabs(
        *[
            error_plot(ERROR_PLOTS[series], pipelines, series)
            for series in ("ate_segments", "rpe_trans", "rpe_rot", "coverage")
        ],
        rrb.TimeSeriesView(
            name=f"features thin, inliers thick · {colour_legend(counted)}",
            contents=_series(counted, "features") + _series(counted, "inliers"),
            plot_legend=hidden_legend(),
        ),
        rrb.TimeSeriesView(
            name=f"pose-graph error · {colour_legend(pipelines)}",
            contents=_series(pipelines, "graph_error"),
            plot_legend=hidden_legend(),
        ),
        *[
            rrb.TimeSeriesView(
                name=f"{name}: time per stage [ms]",
                origin=layout.metric(name, "time"),
                plot_legend=rrb.Corner2D.LeftTop,
            )
            for name in pipelines
        ],
    )
    state = rrb.StateTimelineView(
        name="tracking state and the cause of each loss",
        contents=[path for name in pipelines for path in _series([name], "tracking_state") + _series([name], "cause")],
    )
    # Rejected loop-closure candidates are DEBUG lines: there are many; the view's menu shows them.
    log = rrb.TextLogView(
        origin="log",
        name="tracking and loop-closure log",
        columns=log_columns(),
        rows=rrb.TextLogRows(filter_by_log_level=["INFO", "WARN", "ERROR", "CRITICAL"]),
    )
    state_share = 1.0 + 0.9 * len(pipelines)  # every run's two rows stay in view
    side = rrb.Vertical(matches, ate, details, state, row_shares=[2.4, 2, 2, state_share])
    return rrb.Blueprint(
        rrb.Horizontal(rrb.Vertical(scene, log, row_shares=[3.2, 1]), side, column_shares=[LEFT_SHARE, RIGHT_SHARE]),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", timeline="frame", play_state="following"),
    )


def files_scene_title(runs: list[str], error_top: float) -> str:
    """Groundtruth's and the runs' colours, and the ATE scale the poses are coloured on."""
    ramp = " → ".join(colour.name for colour in palette.ERROR_RAMP)
    return f"groundtruth {palette.GROUNDTRUTH.name} · {colour_legend(runs)} · ATE {ramp}, 0–{error_top:.2f} m"


def files_blueprint(runs: list[str], groundtruth: np.ndarray, error_top: float) -> rrb.Blueprint:
    """The layout of a recording of trajectory files alone: the 3D view of groundtruth and the aligned
    runs over the summary and the log of losses; the ATE of all runs, the other error series in
    tabs and the tracking state. ``groundtruth`` (poses or positions) places the 3D view's eye;
    ``error_top`` is the error the pose colours saturate at, named in the 3D view's title."""
    scene = rrb.Spatial3DView(
        origin="world", name=files_scene_title(runs, error_top), eye_controls=overview_eye(groundtruth, path_only=True)
    )
    text = rrb.Tabs(
        rrb.TextDocumentView(origin=layout.SUMMARY, name="summary"),
        rrb.TextLogView(origin="log", name="losses and recoveries", columns=log_columns()),
    )
    axis = whole_timeline()
    details = rrb.Tabs(
        *[
            error_plot(ERROR_PLOTS[series], runs, series, axis)
            for series in ("ate_segments", "rpe_trans", "rpe_rot", "coverage")
        ]
    )
    state = rrb.StateTimelineView(
        name="tracking state (lost: no pose for longer than the gap rule)",
        contents=_series(runs, "tracking_state"),
        time_view=axis,
    )
    side = rrb.Vertical(
        error_plot(ERROR_PLOTS["ate"], runs, "ate", axis), details, state, row_shares=[2, 2, 0.5 + 0.35 * len(runs)]
    )
    return rrb.Blueprint(
        rrb.Horizontal(rrb.Vertical(scene, text, row_shares=[2.6, 1]), side, column_shares=[LEFT_SHARE, RIGHT_SHARE]),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", timeline="frame", play_state="following"),
    )
