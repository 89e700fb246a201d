#!/usr/bin/env bash
# The checks CI runs before the tests, each configured in pyproject.toml: ruff (style, import
# order and likely bugs; the layout is ruff format's, checked unchanged), mypy (types; strict on the pure core, geometry/ and evaluation/) and
# import-linter (the layers and boundaries that docs/architecture.md describes).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh test
ruff check .
ruff format --check .
mypy
lint-imports
