"""The figures of README.md and docs/ that commands produce are what those commands print now:
`python -m scripts.doc_figures` re-runs them (the demo, the README's estimate example, the diff
example of docs/diagnosis.md), and a block that no longer matches fails here."""

from pathlib import Path

import pytest
from fixtures_eval import TUM_RPY

from benchmarks.figures import with_block, written
from scripts import doc_figures

REPO = Path(__file__).resolve().parents[2]

pytestmark = [pytest.mark.slow, pytest.mark.skipif(not TUM_RPY.is_dir(), reason="shared TUM excerpt not present")]


@pytest.fixture(scope="module")
def figures() -> dict[str, str]:
    return {name: doc_figures.made(name) for name in doc_figures.FIGURES}


@pytest.fixture(scope="module")
def documents() -> dict[str, str]:
    return {figure.document: (REPO / figure.document).read_text() for figure in doc_figures.FIGURES.values()}


def test_every_figure_block_is_what_its_commands_print(figures, documents):
    assert doc_figures.stale(documents, figures) == []


def test_a_doctored_figure_is_found(figures, documents):
    readme = documents["README.md"]
    block = written(readme, "demo")
    digit = next(i for i, character in enumerate(block) if character.isdigit())
    doctored = block[:digit] + str((int(block[digit]) + 1) % 10) + block[digit + 1 :]
    assert doc_figures.stale({**documents, "README.md": with_block(readme, "demo", doctored)}, figures) == ["demo"]
