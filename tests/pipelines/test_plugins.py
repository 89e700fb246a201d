"""Third-party pipelines: real `pip install`s of the plugin packages in tests/pipelines/plugins, then the CLI."""

import json
import os
import shutil
import subprocess
import sys
from importlib.metadata import EntryPoint
from pathlib import Path

import pytest
from benchmark_fake_pipeline import FakePipeline, write_tum_folder

from viewer_slam.errors import InputError
from viewer_slam.pipelines.base import ENTRY_POINT_GROUP, load_plugin

PLUGINS = Path(__file__).parent / "plugins"
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """A folder where pip installed the plugin package (no network, no build isolation)."""
    work = tmp_path_factory.mktemp("plugins")
    source = shutil.copytree(PLUGINS / "viewslam-stationary", work / "viewslam-stationary")
    target = work / "site"
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--quiet",
            "--no-deps",
            "--no-build-isolation",
            "--no-index",
            "--target",
            str(target),
            str(source),
        ],
        check=True,
        capture_output=True,
    )
    return target


def viewslam(site: Path | None, tmp_path: Path, *args: str) -> subprocess.CompletedProcess:
    paths = [str(site)] if site is not None else []
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([*paths, str(ROOT)]), "VIEWSLAM_CACHE": str(tmp_path / "cache")}
    return subprocess.run(
        [sys.executable, "-m", "viewer_slam", *args], env=env, cwd=tmp_path, capture_output=True, text=True, timeout=300
    )


def test_installed_plugin_is_listed_with_its_parameters_and_broken_ones_do_not_hide_the_rest(site, tmp_path):
    listing = viewslam(site, tmp_path, "pipelines")
    assert listing.returncode == 0
    lines = listing.stdout.splitlines()
    headers = [line.split(" (")[0] for line in lines if not line.startswith(" ")]
    assert headers == ["rgbdslam", "rtabmap", "stationary"]
    assert (
        "stationary (plugin from viewslam-stationary 0.1.0): Every frame at the identity pose: the score of not "
        "tracking at all." in lines
    )
    assert lines[-1].split() == [
        "report_every",
        "=",
        "1",
        "(int,",
        ">=",
        "1)",
        "give",
        "a",
        "pose",
        "on",
        "every",
        "N-th",
        "frame",
        "only;",
        "the",
        "frames",
        "between",
        "are",
        "lost",
    ]
    warnings = listing.stderr.splitlines()
    assert sorted(warnings) == [
        "viewslam: warning: pipeline plugin 'not_a_pipeline' (viewslam_stationary:StationaryParams): <class "
        "'viewslam_stationary.StationaryParams'> is not a subclass of viewer_slam.pipelines.base.Pipeline",
        "viewslam: warning: pipeline plugin 'unimportable' (viewslam_stationary.missing:Pipeline): cannot be "
        "imported: ModuleNotFoundError: No module named 'viewslam_stationary.missing'",
    ]


def test_without_the_plugins_only_the_built_in_pipelines_are_listed(tmp_path):
    listing = viewslam(None, tmp_path, "pipelines")
    assert listing.returncode == 0 and listing.stderr == ""
    headings = [line for line in listing.stdout.splitlines() if not line.startswith(" ")]
    assert [line.split(" (")[0] for line in headings] == ["rgbdslam", "rtabmap"]
    # Each pipeline is summed up by its docstring's first paragraph, whole sentences only.
    assert all(line.endswith(".") for line in headings)


def test_a_plugin_records_like_a_built_in_pipeline(site, tmp_path):
    folder = write_tum_folder(tmp_path / "tiny", frames=8)
    done = viewslam(
        site,
        tmp_path,
        "record",
        str(folder),
        "--pipeline",
        "stationary",
        "--max-frames",
        "5",
        "--param",
        "report_every=2",
        "--out",
        "out/tiny.rrd",
        "--quiet",
    )
    assert done.returncode == 0, done.stderr
    report = json.loads((tmp_path / "out/tiny.json").read_text())
    block = report["pipelines"]["stationary"]
    assert block["frames_with_pose"] == 3 and block["parameters"] == {"report_every": 2}
    assert block["ate"]["n"] == 3 and block["ate"]["rmse"] > 0  # the camera of tiny moves; this one does not
    assert [entry["frame"] for entry in block["tracking_lost"]] == [1, 3]
    assert (tmp_path / "out/tiny.stationary.txt").read_text().count("\n") == 3
    assert (tmp_path / "out/tiny.rrd").stat().st_size > 0


@pytest.mark.parametrize(
    "plugin, problem",
    [
        ("unimportable", "cannot be imported: ModuleNotFoundError"),
        ("not_a_pipeline", "is not a subclass of viewer_slam.pipelines.base.Pipeline"),
    ],
)
def test_selecting_a_broken_plugin_is_one_line_and_exit_2(site, tmp_path, plugin, problem):
    folder = write_tum_folder(tmp_path / "tiny", frames=3)
    done = viewslam(site, tmp_path, "record", str(folder), "--pipeline", plugin, "--out", "out/x.rrd", "--quiet")
    assert done.returncode == 2
    assert done.stderr.startswith(f"viewslam: error: pipeline plugin '{plugin}' (") and problem in done.stderr
    assert done.stderr.count("\n") == 1 and not (tmp_path / "out/x.rrd").exists()


def test_a_plugin_runs_in_the_benchmark(site, tmp_path):
    folder = write_tum_folder(tmp_path / "tiny", frames=6)
    done = viewslam(
        site,
        tmp_path,
        "benchmark",
        str(folder),
        "--pipeline",
        "rgbdslam,stationary",
        "--jobs",
        "1",
        "--no-cache",
        "--out",
        "results",
        "--quiet",
    )
    assert done.returncode == 0, done.stderr
    rows = {row["pipeline"]: row for row in json.loads((tmp_path / "results/results.json").read_text())}
    assert set(rows) == {"rgbdslam", "stationary"} and rows["stationary"]["status"] == "ok"
    assert rows["stationary"]["frames_with_pose"] == 6 and rows["stationary"]["ate_rmse"] > 0
    assert "stationary" in (tmp_path / "results/report.md").read_text()


@pytest.mark.parametrize(
    "name, value, problem",
    [
        ("rgbdslam", "benchmark_fake_pipeline:FakePipeline", "the name is taken by a built-in pipeline"),
        ("half", "broken_plugins:HalfPipeline", "HalfPipeline does not implement finish"),
        (
            "bare",
            "broken_plugins:UnparametrisedPipeline",
            "UnparametrisedPipeline.Params is not a subclass of viewer_slam.pipelines.params.PipelineParams",
        ),
        ("value", "benchmark_fake_pipeline:MODULE", "'benchmark_fake_pipeline' is not a subclass of viewer_slam"),
        ("raising", "broken_plugins:no_such_name", "cannot be imported: AttributeError: "),
        (
            "nodefault",
            "broken_plugins:NoDefaultPipeline",
            "NoDefaultPipeline.Params: parameter 'Odom/Window' has no default (every parameter needs one)",
        ),
        (
            "outofbounds",
            "broken_plugins:DefaultOutOfBoundsPipeline",
            "DefaultOutOfBoundsPipeline.Params: the default of parameter window must be greater than or equal to 1, got -1",
        ),
        (
            "rule",
            "broken_plugins:RaisingDefaultsPipeline",
            "RaisingDefaultsPipeline.Params: its defaults cannot be built: ZeroDivisionError: a bug in the plugin's own rule",
        ),
        (
            "earlier",
            "earlier_api_plugin:StationaryParams",
            "cannot be imported: ImportError: viewer_slam.pipelines.params.param is gone: pipeline parameters are a pydantic "
            "model now; use a field of a PipelineParams subclass",
        ),
        (
            "orb/3",
            "benchmark_fake_pipeline:FakePipeline",
            "a pipeline's name holds letters, digits, '_', '-' and '.' only",
        ),
    ],
)
def test_what_a_plugin_must_be(name, value, problem):
    with pytest.raises(InputError) as raised:
        load_plugin(EntryPoint(name, value, ENTRY_POINT_GROUP))
    assert str(raised.value).startswith(f"pipeline plugin {name!r} ({value}): ") and problem in str(raised.value)


def test_a_plugin_that_is_a_pipeline_loads():
    assert load_plugin(EntryPoint("fake", "benchmark_fake_pipeline:FakePipeline", ENTRY_POINT_GROUP)) is FakePipeline


def test_a_plugin_whose_declaration_is_broken_is_one_line_naming_it_and_the_field(monkeypatch, tmp_path, capsys):
    import viewer_slam.pipelines.base as base
    from viewer_slam.cli import main

    point = EntryPoint("nodefault", "broken_plugins:NoDefaultPipeline", ENTRY_POINT_GROUP)
    monkeypatch.setattr(base, "plugin_entry_points", lambda: {"nodefault": point})
    assert main(["record", str(tmp_path / "any"), "--pipeline", "nodefault", "--out", str(tmp_path / "r.rrd")]) == 2
    assert capsys.readouterr().err == (
        "viewslam: error: pipeline plugin 'nodefault' (broken_plugins:NoDefaultPipeline): "
        "NoDefaultPipeline.Params: parameter 'Odom/Window' has no default (every "
        "parameter needs one)\n"
    )
    assert list(tmp_path.iterdir()) == []


def test_every_name_of_the_earlier_parameter_api_says_what_replaced_it():
    import viewer_slam.pipelines.params as params

    for name in ("param", "Ordered", "check_relations", "param_fields", "params_to_dict"):
        with pytest.raises(ImportError, match=rf"^viewer_slam\.pipelines\.params\.{name} is gone: .* use .+"):
            getattr(params, name)
    with pytest.raises(AttributeError):
        params.no_such_name  # noqa: B018
