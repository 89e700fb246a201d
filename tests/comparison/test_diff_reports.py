"""`viewslam diff` on reports that are not of the shape `viewslam record` writes: one line, exit 2."""

import json
import shutil
from pathlib import Path

import pytest
from benchmark_fake_pipeline import MODULE, write_tum_folder

from viewer_slam.cli import main
from viewer_slam.pipelines import base


@pytest.fixture(scope="module")
def report(tmp_path_factory) -> Path:
    """The report (and trajectory) of a 4-frame run of the scripted pipeline."""
    folder = tmp_path_factory.mktemp("run")
    with pytest.MonkeyPatch.context() as patch:
        patch.setitem(base.PIPELINE_MODULES, "fake", MODULE)
        patch.setenv("VIEWSLAM_CACHE", str(folder / "cache"))
        sequence = write_tum_folder(folder / "tiny", frames=4)
        assert main(["record", str(sequence), "--pipeline", "fake", "--out", str(folder / "a.rrd"), "--quiet"]) == 0
    return folder / "a.json"


def edited(report: Path, tmp_path: Path, edit) -> Path:
    data = json.loads(report.read_text())
    result = edit(data)
    data = data if result is None else result
    target = tmp_path / "b.json"
    target.write_text(json.dumps(data))
    shutil.copy(report.with_name("a.fake.txt"), tmp_path / "b.fake.txt")
    return target


def run_block(value):
    return lambda data: data["pipelines"].update(fake=value)


def field(key, value):
    return lambda data: data["pipelines"]["fake"].update({key: value})


@pytest.mark.parametrize(
    "edit, problem",
    [
        (lambda data: [], "not a `viewslam record` report"),
        (lambda data: 5, "not a `viewslam record` report"),
        (lambda data: data.update(pipelines=[]), "not a `viewslam record` report"),
        (run_block(5), "run 'fake' is int, not a run block"),
        (field("tracking_lost", None), "tracking_lost is not a list of losses"),
        (field("tracking_lost", [{"frame": "3"}]), "tracking_lost is not a list of losses"),
        (field("parameters", [1, 2]), "parameters is not an object"),
    ],
    ids=["list", "number", "pipelines-list", "block-number", "losses-null", "loss-frame-text", "parameters-list"],
)
def test_a_malformed_report_is_one_line_naming_it(report, tmp_path, capsys, edit, problem):
    other = edited(report, tmp_path, edit)
    assert main(["diff", str(report), str(other)]) == 2
    error = capsys.readouterr().err
    assert error.startswith(f"viewslam: error: {other}: ") and problem in error and error.count("\n") == 1


def test_the_comparison_is_never_written_over_a_report(report, tmp_path, capsys):
    before = report.read_bytes()
    other = edited(report, tmp_path, lambda data: None)
    assert main(["diff", str(report), str(other), "--json", str(report)]) == 2
    assert capsys.readouterr().err.startswith(f"viewslam: error: --json: {report} is the input A {report}")
    assert report.read_bytes() == before
