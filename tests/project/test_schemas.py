"""The JSON Schemas of viewslam's outputs: real outputs validate, doctored ones do not, and
docs/report-schema.md is what `python -m scripts.schema_docs` generates from them.

The outputs are real: `record` with both pipelines, `evaluate --json` and `benchmark` on a
60-frame synthetic kidnap at 320x240 (rendered once per session, a few seconds each).
"""

import copy
import json
from pathlib import Path

import pytest
from jsonschema import Draft202012Validator

from scripts import schema_docs
from viewer_slam.cli import main
from viewer_slam.dataset.synth import cached_scenario
from viewer_slam.schemas import load_schema, schema_names, validator

ROOT = Path(__file__).resolve().parents[2]
OURS = ("report", "evaluate", "benchmark_results", "study_results")


def errors(name: str, document) -> list[str]:
    """Every validation error as ``path: message``, those inside ``anyOf``/``oneOf`` branches too."""

    def leaves(error):
        yield error
        for inner in error.context or ():
            yield from leaves(inner)

    return [
        f"{'/'.join(map(str, leaf.absolute_path))}: {leaf.message}"
        for error in validator(name).iter_errors(document)
        for leaf in leaves(error)
    ]


@pytest.fixture(scope="module")
def scenario() -> Path:
    return cached_scenario("360_kidnap", frames=60, resolution=(320, 240))


@pytest.fixture(scope="module")
def recorded(scenario, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("record") / "kidnap.rrd"
    assert main(["record", str(scenario), "--out", str(out), "--quiet"]) == 0
    return out


@pytest.fixture(scope="module")
def report(recorded) -> dict:
    return json.loads(recorded.with_suffix(".json").read_text())


@pytest.fixture(scope="module")
def benchmark_out(scenario, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("benchmark")
    assert (
        main(
            [
                "benchmark",
                str(scenario),
                "--pipeline",
                "rtabmap",
                "--out",
                str(out),
                "--jobs",
                "1",
                "--no-cache",
                "--quiet",
            ]
        )
        == 0
    )
    return out


@pytest.mark.parametrize("name", schema_names())
def test_every_schema_is_a_valid_draft_2020_12_schema(name):
    schema = load_schema(name)
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    Draft202012Validator.check_schema(schema)


def _fields(node, path=""):
    """Every (path, field schema) of a schema, through properties, items and $defs."""
    if not isinstance(node, dict):
        return
    for key, child in node.get("properties", {}).items():
        yield f"{path}.{key}", child
        yield from _fields(child, f"{path}.{key}")
    for key in ("items", "additionalProperties"):
        if isinstance(node.get(key), dict):
            yield f"{path}.{key}", node[key]
            yield from _fields(node[key], f"{path}.{key}")
    for key, child in node.get("$defs", {}).items():
        yield f"$defs.{key}", child
        yield from _fields(child, f"$defs.{key}")


@pytest.mark.parametrize("name", OURS)
def test_every_field_is_described(name):
    schema = load_schema(name)
    assert schema.get("description")
    undescribed = [
        path
        for path, field in _fields(schema)
        if "description" not in field and "$ref" not in field and not path.endswith(".items")
    ]
    assert undescribed == []


@pytest.mark.slow
def test_a_real_record_report_validates(report):
    assert set(report["pipelines"]) == {"rgbdslam", "rtabmap"}
    assert any(block["tracking_lost"] for block in report["pipelines"].values())  # the diagnosis' keys are covered
    assert errors("report", report) == []


@pytest.mark.slow
def test_the_record_report_documents_odometry_edges_and_stages(report):
    """The fields the schema defines are the ones written: every run key and every stage named."""
    run = load_schema("report")["$defs"]["run"]
    stages = load_schema("report")["$defs"]["timing"]["properties"]["per_stage_ms"]["description"]
    for block in report["pipelines"].values():
        assert set(block) == set(run["properties"]) - {"trials"}  # only a benchmark's pairs run as trials have it
        assert block["odometry_ate"] is not None and set(block["edges"]) == {"sequential", "local", "loop"}
        assert all(f"`{stage}`" in stages for stage in block["timing"]["per_stage_ms"])


@pytest.mark.slow
@pytest.mark.parametrize(
    "doctor, where",
    [
        (lambda r: r["pipelines"]["rgbdslam"].pop("timing"), "pipelines/rgbdslam"),
        (lambda r: r.pop("versions"), ""),
        (lambda r: r["pipelines"]["rtabmap"]["ate"].update(rmse="0.03"), "pipelines/rtabmap/ate/rmse"),
        (lambda r: r["pipelines"]["rgbdslam"]["edges"].update(loop=1.5), "pipelines/rgbdslam/edges/loop"),
        (lambda r: r["pipelines"]["rgbdslam"]["coverage"].update(ratio=1.2), "pipelines/rgbdslam/coverage/ratio"),
        (lambda r: r["pipelines"]["rtabmap"].update(odometry_error=0.1), "pipelines/rtabmap"),
    ],
)
def test_a_doctored_report_fails(report, doctor, where):
    doctored = copy.deepcopy(report)
    doctor(doctored)
    found = errors("report", doctored)
    assert found and any(error.split(": ", 1)[0] == where for error in found), found


@pytest.mark.slow
def test_evaluate_json_validates_for_one_and_several_estimates(recorded, scenario, tmp_path):
    trajectories = [recorded.with_name(f"{recorded.stem}.{name}.txt") for name in ("rgbdslam", "rtabmap")]
    one, several = tmp_path / "one.json", tmp_path / "several.json"
    assert main(["evaluate", str(scenario), str(trajectories[0]), "--json", str(one)]) == 0
    assert main(["evaluate", str(scenario), *map(str, trajectories), "--json", str(several)]) == 0
    for path in (one, several):
        assert errors("evaluate", json.loads(path.read_text())) == []
    doctored = json.loads(one.read_text())
    del doctored["rpe"]["mode"]
    assert errors("evaluate", doctored)


@pytest.mark.slow
def test_a_real_benchmark_results_json_and_its_run_reports_validate(benchmark_out):
    rows = json.loads((benchmark_out / "results.json").read_text())
    assert [row["status"] for row in rows] == ["ok"]
    assert errors("benchmark_results", rows) == []
    reports = sorted((benchmark_out / "runs").glob("*.json"))
    assert reports and all(errors("report", json.loads(path.read_text())) == [] for path in reports)


@pytest.mark.slow
@pytest.mark.parametrize(
    "doctor",
    [
        lambda row: row.pop("coverage"),
        lambda row: row.update(frames="60"),
        lambda row: row.update(status="done"),
        lambda row: row.update(lost_intervals=[[1.0]]),
    ],
)
def test_a_doctored_benchmark_row_fails(benchmark_out, doctor):
    rows = json.loads((benchmark_out / "results.json").read_text())
    doctor(rows[0])
    assert errors("benchmark_results", rows)


def test_the_schema_page_is_generated_from_the_schemas():
    assert (ROOT / "docs" / "report-schema.md").read_text(encoding="utf-8") == schema_docs.page(), (
        "docs/report-schema.md is out of date: run python -m scripts.schema_docs"
    )
