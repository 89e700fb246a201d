"""`viewslam download`."""

from pathlib import Path

import typer

from .app import app
from .options import QUIET_HELP


@app.command()
def download(
    names: list[str] = typer.Argument(..., help="TUM sequences, e.g. fr2/360_kidnap or rgbd_dataset_freiburg1_xyz."),
    dest: Path = typer.Option(
        None, help="Folder to put the sequences in (default: $VIEWSLAM_DATA, else the viewslam cache)."
    ),
    mirror: str = typer.Option(
        None, help="Base URL holding freiburgN/<name>.tgz (default: $VIEWSLAM_TUM_MIRROR, else the TUM server)."
    ),
    force: bool = typer.Option(False, help="Download again even if the sequence is present."),
    bag: bool = typer.Option(False, "--bag", help="Fetch the sequence's ROS bag (NAME.bag) instead of the archive."),
    quiet: bool = typer.Option(False, "--quiet", help=QUIET_HELP),
) -> None:
    """Download TUM RGB-D sequences (resuming a partial download; verified, then moved into place)."""
    from ..dataset.catalog import known_tum_sequence
    from ..dataset.download import download_sequence

    for name in names:  # every name is checked before anything is downloaded
        known_tum_sequence(name)
    for name in names:
        folder = download_sequence(name, dest, mirror, progress=not quiet, force=force, bag=bag)
        typer.echo(f"{name}: {folder}")
