"""The Rerun viewer binary that ships with rerun-sdk."""

from pathlib import Path


def viewer_binary() -> Path:
    """The bundled `rerun` executable, found without relying on the venv's bin folder being on PATH."""
    import rerun_cli

    return Path(rerun_cli.__file__).with_name("rerun")
