"""Titles and log rows short enough to show whole in a 1280x800 window."""

import numpy as np

from viewer_slam.pipelines.edges import EdgeKind
from viewer_slam.pipelines.events import GraphEdge
from viewer_slam.rerun_adapter import blueprint
from viewer_slam.rerun_adapter.fit import (
    CONTINUATION,
    LEFT_SHARE,
    LOG_LINE_CHARS,
    RIGHT_SHARE,
    column_px,
    log_rows,
    title_chars,
)
from viewer_slam.rerun_adapter.recorder import loop_closure_line

PIPELINES = ["rgbdslam", "rtabmap"]


def views_in(container) -> list:
    """Every view under a blueprint container, tabs included."""
    found = []
    for child in container.contents:
        found += views_in(child) if hasattr(child, "contents") and not hasattr(child, "origin") else [child]
    return found


def test_the_measured_widths_give_these_budgets():
    # At 1280 px: the left column 735 px, the right 545 px, two matches views 272 px each.
    assert (
        title_chars(column_px(LEFT_SHARE)),
        title_chars(column_px(RIGHT_SHARE)),
        title_chars(column_px(RIGHT_SHARE, 2)),
        LOG_LINE_CHARS,
    ) == (93, 63, 21, 91)


def test_every_title_fits_its_view_at_1280x800():
    layout = blueprint.default_blueprint(PIPELINES, np.zeros((2, 3)) + [[0, 0, 0], [1, 1, 0]])
    left, right = layout.root_container.contents
    budgets = {id(view): title_chars(column_px(LEFT_SHARE)) for view in views_in(left)}
    budgets |= {id(view): title_chars(column_px(RIGHT_SHARE)) for view in views_in(right)}
    matches = right.contents[0]
    budgets |= {id(view): title_chars(column_px(RIGHT_SHARE, len(PIPELINES))) for view in matches.contents}
    views = views_in(left) + views_in(right)
    assert len(views) == 2 + len(PIPELINES) + 2 + 6 + len(PIPELINES)  # left 2; matches, ATE, states; 8 tabs
    for view in views:
        assert len(view.name) <= budgets[id(view)], (view.name, budgets[id(view)])


def test_every_title_of_a_recording_of_trajectory_files_fits_at_1280x800():
    runs = ["rgbdslam_v2", "rtabmap"]  # the study's, the longest names shown in docs
    layout = blueprint.files_blueprint(runs, np.array([[0.0, 0, 0], [1, 1, 0]]), error_top=12.34)
    left, right = layout.root_container.contents
    for views, budget in (
        (views_in(left), title_chars(column_px(LEFT_SHARE))),
        (views_in(right), title_chars(column_px(RIGHT_SHARE))),
    ):
        for view in views:
            assert len(view.name) <= budget, (view.name, budget)


def test_one_run_names_its_match_colours_where_two_side_by_side_have_no_room():
    assert "outliers" in blueprint.matches_title("rgbdslam", 1)
    assert blueprint.matches_title("rgbdslam", 2) == "rgbdslam matches"


def test_a_long_message_continues_in_indented_rows_that_fit():
    edges = [
        GraphEdge(
            frame_index=300,
            from_keyframe=27 + k,
            to_keyframe=145,
            accepted=False,
            reason="RANSAC found no transformation with enough inliers",
            kind=EdgeKind.LOOP,
            detection="neighbour",
        )
        for k in range(4)
    ]
    message = f"rgbdslam: {loop_closure_line(edges, 'rejected')}"
    rows = log_rows(message)
    assert len(rows) > 1 and all(len(row) <= LOG_LINE_CHARS for row in rows)
    assert all(row.startswith(CONTINUATION) for row in rows[1:]) and not rows[0].startswith(" ")
    assert " ".join(row.strip() for row in rows) == message
    assert "score" not in message  # a score equal to the inlier count is not repeated
