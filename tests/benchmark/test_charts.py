"""The benchmark's and the study's charts read at any scale: properties of the drawn figures."""

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.text import Text

from viewer_slam.benchmark.plots import CHARTS, draw_metric, plot_metric, uses_log_axis

SEQUENCES = (
    "desk_with_person",
    "pioneer_360",
    "360_kidnap",
    "long_office_household",
    "nostructure_notexture_near_withloop",
    "nostructure_texture_near_withloop",
    "sitting_static",
)
# The study's spread: 0.002 m to 1.94 m, with a failed task and a run without a pose.
ATE = {
    "rgbdslam": (0.003, 0.007, 0.013, 1.938, 0.261, 0.003, 0.003),
    "rtabmap": (0.003, 0.021, 0.131, 0.004, 0.029, 0.003, 0.002),
}


def study_rows(scale: float = 1.0) -> list[dict]:
    rows = []
    for pipeline, values in ATE.items():
        for sequence, value in zip(SEQUENCES, values):
            rows.append(
                {
                    "sequence": sequence,
                    "pipeline": pipeline,
                    "status": "ok",
                    "ate_rmse": value * scale,
                    "rpe_trans_rmse": value * scale,
                    "rpe_rot_rmse": 10 * value,
                    "time_s": 30 + 100 * value,
                    "coverage": min(1.0, 0.3 + value),
                    "penalized_ate_rmse": value * scale,
                }
            )
    rows[-1] = {**rows[-1], **{metric: None for metric in CHARTS}}  # no pose: "n/a"
    rows.append(
        {"sequence": "broken", "pipeline": "rgbdslam", "status": "failed", **{metric: None for metric in CHARTS}}
    )
    return rows


def test_the_axis_is_logarithmic_exactly_where_values_span_more_than_two_decades():
    assert uses_log_axis([0.002, 1.94, None]) and not uses_log_axis([0.02, 1.94]) and not uses_log_axis([0.0, 1.0])
    rows = study_rows()
    for metric, log in (("ate_rmse", True), ("rpe_trans_rmse", True), ("time_s", False), ("coverage", False)):
        figure = draw_metric(rows, metric)
        assert figure.axes[0].get_yscale() == ("log" if log else "linear"), metric
        plt.close(figure)


@pytest.mark.parametrize("scale", [1.0, 0.001])  # metres, and values all below 0.01
def test_every_chart_has_axis_titles_and_tick_labels_inside_the_image(scale):
    for metric in CHARTS:
        figure = draw_metric(study_rows(scale), metric)
        figure.canvas.draw()
        axes = figure.axes[0]
        assert axes.get_ylabel().startswith(CHARTS[metric]) and axes.get_title(loc="left")
        image = figure.bbox
        low, high = sorted(axes.get_ylim())
        labels = [
            label for label in axes.get_yticklabels() if label.get_text() and low <= label.get_position()[1] <= high
        ]
        assert len(labels) >= 2 and len(axes.get_xticklabels()) == len(SEQUENCES) + 1
        labels += axes.get_xticklabels()
        title = next(text for text in figure.findobj(Text) if text.get_text() == CHARTS[metric])
        for label in [*labels, axes.yaxis.label, title]:
            box = label.get_window_extent()
            assert image.x0 <= box.x0 and box.x1 <= image.x1 and image.y0 <= box.y0 and box.y1 <= image.y1, (
                metric,
                label.get_text(),
            )
        assert not title.get_window_extent().overlaps(axes.get_legend().get_window_extent())
        plt.close(figure)


def test_labels_print_small_values_in_full():
    figure = draw_metric(study_rows(0.001), "ate_rmse")
    figure.canvas.draw()
    low, high = figure.axes[0].get_ylim()
    texts = [
        label.get_text()
        for label in figure.axes[0].get_yticklabels()
        if label.get_text() and low <= label.get_position()[1] <= high
    ]
    assert all(text.startswith("0.") or text in ("0", "1") for text in texts), texts  # not ".0030" nor 1e-5
    plt.close(figure)


def test_the_written_image_has_no_blank_margin(tmp_path):
    png, _ = plot_metric(study_rows(), "ate_rmse", tmp_path)
    pixels = plt.imread(png)[..., :3]
    drawn = np.argwhere((pixels < 0.98).any(axis=2))
    (top, left), (bottom, right) = drawn.min(axis=0), drawn.max(axis=0)
    blank = 1 - (bottom - top + 1) * (right - left + 1) / (pixels.shape[0] * pixels.shape[1])
    assert blank < 0.05, f"{blank:.0%} of the image is an empty margin"
