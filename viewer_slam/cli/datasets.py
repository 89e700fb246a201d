"""`viewslam download` and `viewslam sequences`."""

from pathlib import Path

import typer

from .app import app
from .options import QUIET_HELP


@app.command()
def download(
    names: list[str] = typer.Argument(..., help="TUM sequences, e.g. fr2/360_kidnap or rgbd_dataset_freiburg1_xyz."),
    dest: Path = typer.Option(None, help="Folder to put the sequences in (default: $VIEWSLAM_DATA, else the "
                                         "viewslam cache)."),
    mirror: str = typer.Option(None, help="Base URL holding freiburgN/<name>.tgz (default: $VIEWSLAM_TUM_MIRROR, "
                                          "else the TUM server)."),
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


@app.command()
def sequences() -> None:
    """List the synthetic scenarios and the TUM RGB-D sequences, and which are downloaded."""
    from ..dataset.catalog import TUM_SEQUENCES, synthetic_scenarios, tum_cache_dir

    typer.echo("Synthetic scenarios (generated on first use):")
    for scenario in synthetic_scenarios():
        typer.echo(f"  {scenario}")
    folder = tum_cache_dir()
    typer.echo(f"TUM RGB-D sequences (downloads in {folder}):")
    alias_width = max(len(info.alias) for info in TUM_SEQUENCES)
    for info in TUM_SEQUENCES:
        groundtruth = "groundtruth" if info.groundtruth_public else "no-groundtruth"
        typer.echo(f"  {info.alias:<{alias_width}}  {info.category:<21}  {groundtruth:<14}  "
                   f"{_state(folder, info.name)}".rstrip())
    typer.echo("frN/NAME stands for the folder rgbd_dataset_freiburgN_NAME; commands accept either.")


def _state(folder: Path, name: str) -> str:
    """``downloaded``, ``bag`` (its ROS bag is downloaded), ``partial`` (an interrupted download
    that the next one resumes) or nothing."""
    from ..dataset.download import partial_archive

    if (folder / name).is_dir():
        return "downloaded"
    if (folder / f"{name}.bag").is_file():
        return "bag"
    return "partial" if any(partial_archive(folder, name, bag).is_file() for bag in (False, True)) else ""
