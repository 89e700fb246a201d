"""JSON Schemas (draft 2020-12) of viewslam's JSON outputs, shipped with the package.

- ``report.schema.json``: the report `viewslam record` writes beside a recording (and
  `benchmark` writes per sequence in ``OUT/runs/``);
- ``evaluate.schema.json``: what `viewslam evaluate --json` writes;
- ``benchmark_results.schema.json``: `viewslam benchmark`'s ``results.json``.

The schemas are plain data: reading them needs no validator. docs/report-schema.md is
generated from them (``scripts/schema_docs.py``).
"""

import json
from importlib import resources
from typing import Any

SUFFIX = ".schema.json"


def schema_names() -> list[str]:
    """Every schema shipped, by file name without ``.schema.json``, sorted."""
    folder = resources.files(__name__)
    return sorted(entry.name[: -len(SUFFIX)] for entry in folder.iterdir() if entry.name.endswith(SUFFIX))


def load_schema(name: str) -> dict[str, Any]:
    """The schema ``name`` (``"report"``, ``"evaluate"``, ``"benchmark_results"``, ...) as a dict."""
    return json.loads(resources.files(__name__).joinpath(name + SUFFIX).read_text(encoding="utf-8"))


def schema_id(name: str) -> str:
    """The URI the schema ``name`` is known by: its ``$id``, else ``urn:viewslam:schema:<name>``."""
    return load_schema(name).get("$id", f"urn:viewslam:schema:{name}")


def validator(name: str):
    """A draft 2020-12 validator of the schema ``name``, which resolves references between the
    shipped schemas. Needs the ``jsonschema`` package (in the ``dev`` extra)."""
    from jsonschema import Draft202012Validator
    from referencing import Registry, Resource

    registry = Registry().with_resources(
        (schema_id(other), Resource.from_contents(load_schema(other))) for other in schema_names()
    )
    return Draft202012Validator(load_schema(name), registry=registry)
