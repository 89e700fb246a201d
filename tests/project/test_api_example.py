"""docs/api.md's worked example runs as it is written, and says what the page says it does: the
library's functions chained (synth, record, evaluate) give the ATE the record's own report gives."""

import contextlib
import io
import json
import re
from pathlib import Path

import pytest

API_PAGE = Path(__file__).resolve().parents[2] / "docs" / "api.md"
PRINTED = re.compile(r"^office\.rgbdslam\.txt: ATE RMSE (\d+\.\d{4}) m over (\d+) poses$")


def example_code() -> str:
    """The page's worked example: the python block under its heading."""
    section = API_PAGE.read_text().split("## A worked example", 1)[1]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_every_command_is_a_function_of_the_package():
    import viewer_slam
    from viewer_slam import benchmark, diff, evaluate, record, study, synth

    for face in (benchmark, diff, evaluate, record, study, synth):
        assert callable(face)
    with pytest.raises(AttributeError):
        viewer_slam.no_such_command  # noqa: B018


def test_the_worked_example_runs_and_scores_as_the_record_does(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    printed = io.StringIO()
    namespace = {"__name__": "example"}
    with contextlib.redirect_stdout(printed):
        exec(compile(example_code(), str(API_PAGE), "exec"), namespace)
    match = PRINTED.match(printed.getvalue().strip())
    assert match, printed.getvalue()
    report = json.loads((tmp_path / "office.json").read_text())["pipelines"]["rgbdslam"]
    assert int(match.group(2)) == report["ate"]["n"] == 20  # every frame of the 20 has a pose pair
    assert float(match.group(1)) == pytest.approx(report["ate"]["rmse"], abs=5e-5)  # printed to 4 decimals
    scored_file = namespace["run"].evaluation.ate.stats()["rmse"]
    # the record scored its poses in memory, evaluate the file that holds them as text (six decimals)
    assert scored_file == pytest.approx(report["ate"]["rmse"], rel=1e-5)
    assert report["ate"]["rmse"] < 0.25  # a tracked office round (0.086 m when written), not a lost one
    assert all((tmp_path / name).is_file() for name in ("office.rrd", "office.rgbdslam.txt", "office/groundtruth.txt"))
