"""benchmarks.rtabmap: its cases run minutes each, so here only its command line and its refusals."""

import pytest

from benchmarks import rtabmap
from viewer_slam.errors import InputError


def test_help_names_every_case(capsys):
    with pytest.raises(SystemExit) as exit_:
        rtabmap.main(["--help"])
    assert exit_.value.code == 0
    printed = capsys.readouterr().out
    assert all(case in printed for case in rtabmap.CASES) and "--param KEY=VALUE" in printed


def test_an_unknown_case_is_refused():
    with pytest.raises(SystemExit) as exit_:
        rtabmap.main(["sped"])
    assert exit_.value.code == 2


def test_a_bad_parameter_is_refused_before_the_first_case(monkeypatch):
    monkeypatch.setitem(rtabmap.CASES, "speed", lambda options: pytest.fail("a case ran"))
    with pytest.raises(InputError, match="Odom/ResetCountdown expects an integer"):
        rtabmap.main(["speed", "--param", "Odom/ResetCountdown=soon"])


def test_a_case_runs_with_the_command_lines_parameters_under_its_own(tiny_scene, monkeypatch):
    options = rtabmap.argparse.Namespace(param=["Vis/MinInliers=12", "Rtabmap/DetectionRate=3"], config=None)
    sequence, run, events = rtabmap.run(
        options, str(tiny_scene), 0, (320, 240), max_frames=4, overrides={"Rtabmap/DetectionRate": 10}
    )
    assert run.frames == 4 and len(events) >= 4
    assert run.parameters["Vis/MinInliers"] == 12 and run.parameters["Rtabmap/DetectionRate"] == 10
    assert rtabmap.ate(sequence, run.trajectory) < 0.05
