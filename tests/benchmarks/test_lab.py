"""What every script shares: parameters set as `viewslam record` sets them, in layers; runs through
the run service; bad input as one line and exit code 2; the figure blocks of the documents."""

import argparse
import subprocess
import sys
from pathlib import Path

import pytest

from benchmarks import figures, lab
from viewer_slam.dataset.sources import open_source
from viewer_slam.errors import InputError
from viewer_slam.pipelines.run import run_pipeline

REPO = Path(__file__).resolve().parents[2]


def options(*params: str, config: Path | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    lab.add_parameter_options(parser)
    return parser.parse_args([*(f"--param={item}" for item in params), *(["--config", str(config)] if config else [])])


def test_parameters_come_in_layers_config_preset_param_last(tmp_path):
    config = tmp_path / "config.toml"
    config.write_text('"Odom/ResetCountdown" = 3\n"Vis/MinInliers" = 25\n"Rtabmap/DetectionRate" = 2\n')
    spec = lab.pipeline_spec(
        "rtabmap",
        options("Vis/MinInliers=30", "Kp/MaxFeatures=400", config=config),
        preset={"Odom/ResetCountdown": 7, "Vis/MinInliers": 11},
        last={"Kp/MaxFeatures": 500},
    )
    values = spec.params.model_dump(by_alias=True)
    assert values["Rtabmap/DetectionRate"] == 2  # the config alone
    assert values["Odom/ResetCountdown"] == 7  # the preset over the config
    assert values["Vis/MinInliers"] == 30  # --param over the preset
    assert values["Kp/MaxFeatures"] == 500  # the script's own value last
    assert lab.pipeline_spec("rtabmap").params == type(spec.params)()  # no options: the defaults


@pytest.mark.parametrize(
    ("item", "problem"),
    [
        ("Vis/MinInliers=many", "Vis/MinInliers expects an integer, got 'many'"),
        ("No/Such=1", "unknown parameter 'No/Such'"),
        ("Vis/MinInliers", "expected KEY=VALUE"),
    ],
)
def test_bad_parameters_are_refused_as_record_refuses_them(item, problem):
    with pytest.raises(InputError, match=problem):
        lab.pipeline_specs(["rtabmap"], options(item))


def test_a_run_through_the_service_is_the_bare_pipeline_run_and_scored(tiny_scene):
    sequence = open_source(tiny_scene)
    spec = lab.pipeline_spec("rtabmap", options("Vis/MinInliers=12"))
    scored = lab.run(sequence, spec, "rtabmap", max_frames=6)
    bare = run_pipeline(sequence, "rtabmap", spec.params, max_frames=6)
    assert scored.run.frames == bare.frames == 6
    assert scored.run.parameters["Vis/MinInliers"] == 12
    assert (scored.run.trajectory.poses == bare.trajectory.poses).all()
    assert scored.report["ate"]["rmse"] == pytest.approx(lab.ate_rmse(sequence.groundtruth, scored.run.trajectory))


def test_bad_input_ends_in_one_line_and_exit_code_2():
    done = subprocess.run(
        [sys.executable, "-m", "benchmarks.peer", "--param", "Vis/MinInliers=many"],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        "error: --param: parameter Vis/MinInliers expects an integer, got 'many'"
    ]


def test_a_block_is_replaced_in_place_and_a_missing_one_named():
    text = (
        "intro\n<!-- oracle: kidnap -->\nold\n<!-- /oracle: kidnap -->\n<!-- figures: kidnap -->\nkept\n"
        "<!-- /figures: kidnap -->\n"
    )
    replaced = figures.with_block(text, "kidnap", "new\nlines", "oracle")
    assert figures.written(replaced, "kidnap", "oracle") == "new\nlines"
    assert figures.written(replaced, "kidnap") == "kept"
    assert replaced.startswith("intro\n") and replaced.endswith("<!-- /figures: kidnap -->\n")
    with pytest.raises(ValueError, match="no figures block 'absent'"):
        figures.with_block(text, "absent", "x")


def test_a_stamp_names_the_command_the_machine_and_the_commit():
    stamp = figures.stamp(figures.invocation("python -m benchmarks.peer", ["--sequence", "X"]))
    assert stamp.startswith("Made by `python -m benchmarks.peer --sequence X` on ")
    assert " cores), " in stamp and " at " in stamp


def test_no_script_edits_the_import_path():
    sources = [*(REPO / "benchmarks").glob("*.py"), *(REPO / "scripts").glob("*.py")]
    assert len(sources) > 15
    assert [path.name for path in sources if "sys.path" in path.read_text()] == []
