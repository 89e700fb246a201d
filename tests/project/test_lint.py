"""ruff and the import contracts (pyproject.toml) hold, so the test command alone enforces them.
mypy, slower, runs in scripts/lint.sh."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def tool(name: str) -> str:
    """The tool installed beside this interpreter (the test install), else the one on PATH."""
    beside = Path(sys.executable).parent / name
    found = str(beside) if beside.exists() else shutil.which(name)
    if found is None:
        pytest.fail(f"{name} is not installed: install the test extras (bash scripts/setup.sh test)")
    return found


@pytest.mark.parametrize("command", [["ruff", "check", "--quiet", "."], ["lint-imports", "--no-cache"]])
def test_check_passes(command):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    result = subprocess.run([tool(command[0]), *command[1:]], cwd=ROOT, env=env, capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr
