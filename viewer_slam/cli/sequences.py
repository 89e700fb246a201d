"""`viewslam sequences`."""

import os
from pathlib import Path

import typer
from rich.filesize import decimal

from .app import app


@app.command()
def sequences(
    clear_cache: bool = typer.Option(
        False,
        "--clear-cache",
        help="Remove the rendered scenarios, benchmark results and study files from the "
        "cache (downloaded TUM sequences stay), then list.",
    ),
) -> None:
    """List the synthetic scenarios and the TUM RGB-D sequences, which are downloaded, and what
    the cache holds (location, size of each entry and in all)."""
    from ..cache import cache_root
    from ..cache import clear_cache as clear
    from ..dataset.catalog import TUM_SEQUENCES, synthetic_scenarios, tum_cache_dir

    if clear_cache:
        removed = clear()
        typer.echo(
            f"Removed {len(removed)} cache entr{'y' if len(removed) == 1 else 'ies'}, "
            f"{decimal(sum(entry.size for entry in removed))}."
        )
    typer.echo(f"Synthetic scenarios (generated on first use into {cache_root() / 'synth'}):")
    for scenario in synthetic_scenarios():
        typer.echo(f"  {scenario}")
    folder = tum_cache_dir()
    typer.echo(f"TUM RGB-D sequences (downloads in {folder}):")
    alias_width = max(len(info.alias) for info in TUM_SEQUENCES)
    for info in TUM_SEQUENCES:
        groundtruth = "groundtruth" if info.groundtruth_public else "no-groundtruth"
        typer.echo(
            f"  {info.alias:<{alias_width}}  {info.category:<21}  {groundtruth:<14}  "
            f"{_state(folder, info.name)}".rstrip()
        )
    typer.echo("frN/NAME stands for the folder rgbd_dataset_freiburgN_NAME; commands accept either.")
    _print_cache()


def _print_cache() -> None:
    """The cache's folder and total, then each entry's size."""
    from ..cache import cache_entries, cache_root

    entries = cache_entries()
    source = "$VIEWSLAM_CACHE" if os.environ.get("VIEWSLAM_CACHE") else "default; set VIEWSLAM_CACHE to move it"
    typer.echo(f"Cache {cache_root()} ({source}): {decimal(sum(entry.size for entry in entries))}")
    width = max((len(entry.name) for entry in entries), default=0)
    for entry in entries:
        typer.echo(f"  {entry.name:<{width}}  {decimal(entry.size):>9}")
    typer.echo("`viewslam sequences --clear-cache` removes all of it but the downloads (tum/).")


def _state(folder: Path, name: str) -> str:
    """``downloaded``, ``bag`` (its ROS bag is downloaded), ``partial`` (an interrupted download
    that the next one resumes) or nothing."""
    from ..dataset.download import partial_archive

    if (folder / name).is_dir():
        return "downloaded"
    if (folder / f"{name}.bag").is_file():
        return "bag"
    return "partial" if any(partial_archive(folder, name, bag).is_file() for bag in (False, True)) else ""
