"""The figure blocks of README.md and docs/: the figures a command made, in the document beside it.

A block sits between two markers, ``<!-- KIND: NAME -->`` and ``<!-- /KIND: NAME -->``: kind
``figures`` for the blocks ``python -m scripts.doc_figures`` and the benchmarks write, ``oracle``
for the tables of ``python -m benchmarks.oracle``. A figure too costly for the test suite is
stamped with the command that made it, the machine, the date and the commit (:func:`stamp`).
"""

import atexit
import os
import re
import shutil
import subprocess
import tempfile
from collections.abc import Sequence
from datetime import date
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"
"""The data beside the repository: TUM excerpts, the study's published runs, the original's runs."""
TUM = SHARED_DATA / "tum"


def invocation(prog: str, arguments: Sequence[str]) -> str:
    """The command line a script was run with, as a stamp records it: its ``prog`` (``python -m
    benchmarks.NAME``) and ``arguments``."""
    return " ".join([prog, *arguments])


def stamp(command: str) -> str:
    """Where a figure too costly for the test suite came from: the command, the machine, the
    date, and the version and commit of viewslam that ran it."""
    from viewer_slam import __version__

    cpu = next(
        (
            line.split(":", 1)[1].strip()
            for line in Path("/proc/cpuinfo").read_text().splitlines()
            if line.startswith("model name")
        ),
        "unknown CPU",
    )
    commit = (
        subprocess.run(
            ["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=False
        ).stdout.strip()
        or "unknown commit"
    )
    return (
        f"Made by `{command}` on {cpu} ({os.cpu_count()} cores), {date.today().isoformat()}, "
        f"viewslam {__version__} at {commit}."
    )


def scratch() -> Path:
    """A new temporary folder, removed when this process ends."""
    folder = Path(tempfile.mkdtemp(prefix="viewslam-figures-"))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    return folder


def _block(name: str, kind: str) -> re.Pattern[str]:
    return re.compile(rf"(<!-- {kind}: {re.escape(name)} -->\n)(.*?)(<!-- /{kind}: {re.escape(name)} -->)", re.DOTALL)


def written(text: str, name: str, kind: str = "figures") -> str:
    """The block ``name`` as the document ``text`` holds it."""
    found = _block(name, kind).search(text)
    if found is None:
        raise ValueError(f"no {kind} block {name!r}")
    return found.group(2).removesuffix("\n")


def with_block(text: str, name: str, content: str, kind: str = "figures") -> str:
    """The document ``text`` with the block ``name`` replaced by ``content``."""
    written(text, name, kind)
    return _block(name, kind).sub(lambda found: found.group(1) + content + "\n" + found.group(3), text)


def write_block(document: Path, name: str, content: str, kind: str = "figures") -> None:
    """The block ``name`` of ``document`` replaced by ``content``, in place."""
    document.write_text(with_block(document.read_text(), name, content, kind))
