"""`evaluate --plot`'s picture: a legend of what is drawn, and no two lines of one estimate on one another."""

import matplotlib.pyplot as plt
import pytest
from fixtures_eval import TRAJECTORIES
from matplotlib.colors import to_hex

from viewer_slam.evaluation import evaluate
from viewer_slam.evaluation.plot import Scored, draw_evaluation
from viewer_slam.geometry.trajectory import read_tum

GROUNDTRUTH = read_tum(TRAJECTORIES / "freiburg1_xyz-groundtruth.txt")
ESTIMATE = read_tum(TRAJECTORIES / "freiburg1_xyz-rgbdslam.txt")


def scored(label: str, estimate) -> Scored:
    return Scored(label, estimate, evaluate(GROUNDTRUTH, estimate))


def legend_texts(figure) -> list[str]:
    return [text.get_text() for legend in figure.legends for text in legend.get_texts()]


@pytest.fixture
def quitter():
    middle = (ESTIMATE.timestamps[0] + ESTIMATE.timestamps[-1]) / 2
    return ESTIMATE.subset(ESTIMATE.timestamps <= middle)


def test_with_no_loss_the_legend_names_no_lost_time():
    figure = draw_evaluation(GROUNDTRUTH, [scored("steady", ESTIMATE)])
    assert legend_texts(figure) == ["groundtruth", "steady (rigid)"]
    assert not any(patch for axes in figure.axes for patch in axes.patches)  # and no shading
    plt.close(figure)


def test_a_loss_is_shaded_on_every_error_panel_and_named_once(quitter):
    figure = draw_evaluation(GROUNDTRUTH, [scored("steady", ESTIMATE), scored("quitter", quitter)])
    texts = legend_texts(figure)
    assert texts[:3] == ["groundtruth", "steady (rigid)", "quitter (rigid)"] and sum("lost" in t for t in texts) == 1
    panels = [axes for axes in figure.axes if axes.get_xlabel() != "x [m]"]
    assert len(panels) == 3 and all(axes.patches for axes in panels)
    plt.close(figure)


def test_each_error_panel_has_one_line_per_estimate_and_says_what_it_shows(quitter):
    figure = draw_evaluation(GROUNDTRUTH, [scored("steady", ESTIMATE), scored("quitter", quitter)])
    panels = [axes for axes in figure.axes if axes.get_xlabel() != "x [m]"]
    titles = [axes.get_title(loc="left") for axes in panels]
    assert titles[0].startswith("ATE (rigid") and "segment" in titles[1] and "penalised" in titles[2]
    for axes in panels:
        colours = [to_hex(line.get_color()) for line in axes.get_lines()]
        assert len(colours) == 2 and len(set(colours)) == 2  # one line each, told apart by colour
        assert {line.get_linestyle() for line in axes.get_lines()} == {"-"}
        assert axes.get_ylabel() == "error [m]"
    plt.close(figure)
