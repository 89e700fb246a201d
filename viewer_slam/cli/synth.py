"""`viewslam synth`: write a synthetic scenario as a TUM RGB-D folder."""

from pathlib import Path

import typer

from ..dataset.synth.catalog import MAX_FRAMES
from ..seeds import SEED_MAX
from .app import app
from .options import QUIET_HELP, parse_resolution


@app.command()
def synth(
    scenario: str = typer.Argument(..., help="Scenario name (see `viewslam sequences`)."),
    out: Path = typer.Option(..., "--out", help="Folder to write the TUM sequence into."),
    frames: int = typer.Option(
        None, min=1, max=MAX_FRAMES, help="Number of frames; default: the scenario's own length.", show_default=False
    ),
    resolution: str = typer.Option("640x480", help="Image size WIDTHxHEIGHT; the intrinsics are scaled."),
    seed: int = typer.Option(
        0, min=0, max=SEED_MAX, help="Seed of the scene, the motion's tremor and the sensor noise."
    ),
    camera: str = typer.Option("fr3", help="Intrinsics of TUM's freiburg camera: fr1, fr2 or fr3."),
    force: bool = typer.Option(False, "--force", help="Overwrite an existing non-empty folder."),
    quiet: bool = typer.Option(False, "--quiet", help=QUIET_HELP),
) -> None:
    """Render a synthetic scenario (rgb/, depth/, rgb.txt, depth.txt, groundtruth.txt, camera.json)."""
    from ..dataset.synth.command import synth as render

    result = render(
        scenario,
        out,
        frames=frames,
        resolution=parse_resolution(resolution),
        seed=seed,
        camera=camera,
        force=force,
        quiet=quiet,
    )
    typer.echo(
        f"{result.folder}: {result.frames} frames of {result.scenario} at "
        f"{result.resolution[0]}x{result.resolution[1]} ({result.notes})"
    )
