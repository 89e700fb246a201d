"""Each run has one colour: the same in the recording, the benchmark charts and the terminal."""

import re

from rerun.chunk import RrdReader
from rich.console import Console

from viewer_slam import palette
from viewer_slam.benchmark.plots import plot_metric
from viewer_slam.record.console import print_summary

PIPELINES = ("rgbdslam", "rtabmap")


def unpack_rgba(packed: int) -> tuple[int, int, int]:
    return (packed >> 24) & 255, (packed >> 16) & 255, (packed >> 8) & 255


def static_colours(path, entity: str, column: str) -> list[tuple[int, int, int]]:
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.entity_path == entity and chunk.is_static:
            batch = chunk.to_record_batch().to_pydict()
            if column in batch:
                return [unpack_rgba(value) for value in batch[column][-1]]
    raise AssertionError(f"no static {column} at {entity}")


def viewer_colours(recording) -> dict[str, set]:
    """The colours the recording gives each pipeline's ATE plot line and final trajectory."""
    return {
        name: {
            *static_colours(recording, f"/metrics/{name}/ate", "SeriesLines:colors"),
            *static_colours(recording, f"/world/{name}/trajectory", "LineStrips3D:colors"),
        }
        for name in PIPELINES
    }


def chart_colours(tmp_path) -> dict[str, set]:
    """The fill colours of each pipeline's bars in the benchmark chart's SVG, by legend entry."""
    rows = [
        {"sequence": sequence, "pipeline": name, "status": "ok", "ate_rmse": 0.1 + k}
        for sequence in ("a", "b")
        for k, name in enumerate(PIPELINES)
    ]
    svg = plot_metric(rows, "ate_rmse", tmp_path)[1].read_text()
    colours = {}
    for name in PIPELINES:  # each legend text follows its legend patch
        patch = re.findall(r"fill: (#[0-9a-f]{6})", svg[: svg.index(f"<!-- {name} -->")])[-1]
        colours[name] = {tuple(int(patch[i : i + 2], 16) for i in (1, 3, 5))}
    return colours


def terminal_colours() -> dict[str, set]:
    """The truecolor the summary table prints each pipeline's name in."""
    block = {
        "frames_with_pose": 1,
        "coverage": None,
        "ate": None,
        "penalized_ate": None,
        "rpe": None,
        "loop_closures": {"accepted": 0, "rejected": 0},
        "timing": {"fps": 1.0},
    }
    report = {"sequence": {"name": "x"}, "interrupted": False, "pipelines": {name: block for name in PIPELINES}}
    console = Console(record=True, force_terminal=True, color_system="truecolor", width=100)
    print_summary(report, [], console)
    text = console.export_text(styles=True)
    return {
        name: {tuple(map(int, re.search(rf"\x1b\[[0-9;]*38;2;(\d+);(\d+);(\d+)m{name}", text).groups()))}
        for name in PIPELINES
    }


def test_viewer_charts_and_terminal_take_the_same_colour_for_each_pipeline(recorded, tmp_path):  # noqa: F811
    viewer, charts, terminal = viewer_colours(recorded.recording), chart_colours(tmp_path), terminal_colours()
    for name in PIPELINES:
        assert viewer[name] == charts[name] == terminal[name] == {palette.run_colour(name).rgb}, name
    assert palette.run_colour("rgbdslam") != palette.run_colour("rtabmap")


def test_other_runs_get_distinct_stable_fallback_colours():
    runs = ["rgbdslam", "my_plugin", "imported", "rtabmap"]
    colours = [palette.run_colour(name, position) for position, name in enumerate(runs)]
    assert len(set(colours)) == len(runs)
    assert colours == [palette.run_colour(name, position) for position, name in enumerate(runs)]
    assert not {colour.rgb for colour in colours[1:3]} & {c.rgb for c in palette.PIPELINE_COLOURS.values()}
    assert palette.run_colour("rgbdslam", 5) == palette.PIPELINE_COLOURS["rgbdslam"]  # position never matters
    assert palette.Colour((255, 140, 0), "orange").hex == "#ff8c00"
