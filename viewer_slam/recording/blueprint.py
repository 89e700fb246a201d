"""The layout a recording opens with: 3D scene left; matches, error plots and log right."""

import numpy as np
import rerun.blueprint as rrb

from .. import palette
from ..pipelines.edges import EdgeKind
from . import layout
from .sizes import extent


def _series(pipelines: list[str], series: str) -> list[str]:
    return [f"/{layout.metric(name, series)}" for name in pipelines]


def overview_eye(positions: np.ndarray) -> rrb.EyeControls3D:
    """A three-quarter view from above that frames the camera path and the room around it
    (the room reaches beyond a short path: the distance has a floor)."""
    centre = positions.mean(axis=0)
    direction = np.array([-0.35, -0.5, 1.0])
    distance = 1.6 * extent(positions) + 0.5
    return rrb.EyeControls3D(kind="Orbital", position=centre + distance * direction / np.linalg.norm(direction),
                             look_target=centre, eye_up=[0.0, 0.0, 1.0])


def default_blueprint(pipelines: list[str], groundtruth_positions: np.ndarray | None = None,
                      counted: list[str] | None = None) -> rrb.Blueprint:
    """3D view of groundtruth and every pipeline; per pipeline its image with matches; the
    ATE of all pipelines in one plot, the other metrics in tabs, tracking state and log.

    With groundtruth, the 3D view opens looking at its camera path. The features / inliers
    plot shows the ``counted`` runs (default: all; an imported estimate has no counts)."""
    counted = pipelines if counted is None else counted
    eye = overview_eye(groundtruth_positions) if groundtruth_positions is not None else None
    # Keyframe depth clouds, the many rejected loop closures and the local edges (short chords
    # among recent keyframes) would bury the map and the trajectories; one click shows them.
    hidden = {f"/{path}": rrb.EntityBehavior(visible=False) for name in pipelines
              for path in (f"{layout.latest_keyframe(name)}/depth", layout.rejected_loop_closures(name),
                           layout.edges(name, EdgeKind.LOCAL.value))}
    legend = ", ".join(f"{name} {palette.run_colour(name, i).name}" for i, name in enumerate(pipelines))
    scene = rrb.Spatial3DView(origin="world", name=f"groundtruth {palette.GROUNDTRUTH.name}, {legend}; "
                                                   f"loop closures {palette.ACCEPTED.name}",
                              eye_controls=eye, overrides=hidden)
    matches = rrb.Horizontal(*[
        rrb.Spatial2DView(origin=layout.matches(name), contents=[f"/{layout.CAMERA_IMAGE}", "$origin/**"],
                          name=f"{name} matches")
        for name in pipelines])
    ate = rrb.TimeSeriesView(name="ATE per frame, one alignment for the run [m]", contents=_series(pipelines, "ate"),
                             plot_legend=rrb.Corner2D.LeftTop)
    details = rrb.Tabs(
        rrb.TimeSeriesView(name="ATE per frame, each tracked segment aligned on its own [m]",
                           contents=_series(pipelines, "ate_segments")),
        rrb.TimeSeriesView(name="RPE translation [m], Δ=1 s", contents=_series(pipelines, "rpe_trans")),
        rrb.TimeSeriesView(name="RPE rotation [deg], Δ=1 s", contents=_series(pipelines, "rpe_rot")),
        rrb.TimeSeriesView(name="coverage so far", contents=_series(pipelines, "coverage")),
        rrb.TimeSeriesView(name="features / inliers",
                           contents=_series(counted, "features") + _series(counted, "inliers")),
        rrb.TimeSeriesView(name="pose-graph error after optimisation", contents=_series(pipelines, "graph_error")),
        *[rrb.TimeSeriesView(name=f"{name}: time per stage [ms]", origin=layout.metric(name, "time"))
          for name in pipelines],
    )
    state = rrb.StateTimelineView(name="tracking state and the cause of each loss",
                                  contents=_series(pipelines, "tracking_state") + _series(pipelines, "cause"))
    # Rejected loop-closure candidates are DEBUG lines: there are many; the view's menu shows them.
    log = rrb.TextLogView(origin="log", name="tracking and loop-closure log",
                          rows=rrb.TextLogRows(filter_by_log_level=["INFO", "WARN", "ERROR", "CRITICAL"]))
    side = rrb.Vertical(matches, ate, details, state, log, row_shares=[3, 2, 2, 1.6, 2])
    return rrb.Blueprint(
        rrb.Horizontal(scene, side, column_shares=[3, 2]),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", timeline="frame", play_state="following"),
    )
