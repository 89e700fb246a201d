"""`viewslam download` and `viewslam sequences`."""

from pathlib import Path

import typer

from .app import app


@app.command()
def download(
    names: list[str] = typer.Argument(..., help="TUM sequences, e.g. fr2/360_kidnap or rgbd_dataset_freiburg1_xyz."),
    dest: Path = typer.Option(None, help="Folder to put the sequences in (default: the viewslam cache)."),
    mirror: str = typer.Option(None, help="Base URL holding freiburgN/<name>.tgz (default: the TUM server)."),
    force: bool = typer.Option(False, help="Download again even if the sequence is present."),
    quiet: bool = typer.Option(False, help="No progress bar."),
) -> None:
    """Download TUM RGB-D sequences (verified, then moved into place)."""
    from ..dataset.download import TUM_MIRROR, download_sequence

    for name in names:
        folder = download_sequence(name, dest, mirror or TUM_MIRROR, progress=not quiet, force=force)
        typer.echo(f"{name}: {folder}")


@app.command()
def sequences() -> None:
    """List the synthetic scenarios and the TUM RGB-D sequences, and which are downloaded."""
    from ..dataset.catalog import TUM_SEQUENCES, synthetic_scenarios, tum_cache_dir

    typer.echo("Synthetic scenarios (generated on first use):")
    for scenario in synthetic_scenarios():
        typer.echo(f"  {scenario}")
    cache = tum_cache_dir()
    typer.echo(f"TUM RGB-D sequences (downloads in {cache}):")
    width = max(len(info.alias) for info in TUM_SEQUENCES)
    for info in TUM_SEQUENCES:
        state = "downloaded" if (cache / info.name).is_dir() else ""
        typer.echo(f"  {info.alias:<{width}}  {info.name:<52}  {info.category:<21}  {state}".rstrip())
