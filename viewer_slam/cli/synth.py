"""`viewslam synth`: write a synthetic scenario as a TUM RGB-D folder."""

import re
from pathlib import Path

import typer

from ..errors import InputError
from .app import app


def parse_resolution(text: str) -> tuple[int, int]:
    """``WIDTHxHEIGHT`` (e.g. ``640x480``) as a pair of integers."""
    match = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if match is None:
        raise InputError(f"bad resolution {text!r}; valid: WIDTHxHEIGHT, e.g. 640x480 or 320x240")
    return int(match.group(1)), int(match.group(2))


@app.command()
def synth(
    scenario: str = typer.Argument(..., help="Scenario name (see `viewslam sequences`)."),
    out: Path = typer.Option(..., "--out", help="Folder to write the TUM sequence into."),
    frames: int = typer.Option(None, help="Number of frames; default: the scenario's own length.",
                               show_default=False),
    resolution: str = typer.Option("640x480", help="Image size WIDTHxHEIGHT; the intrinsics are scaled."),
    seed: int = typer.Option(0, help="Seed of the scene, the motion's tremor and the sensor noise."),
    camera: str = typer.Option("fr3", help="Intrinsics of TUM's freiburg camera: fr1, fr2 or fr3."),
    force: bool = typer.Option(False, "--force", help="Overwrite an existing non-empty folder."),
) -> None:
    """Render a synthetic scenario (rgb/, depth/, rgb.txt, depth.txt, groundtruth.txt, camera.json)."""
    from ..dataset.synth import generate_scenario, read_info

    folder = generate_scenario(scenario, out, frames=frames, resolution=parse_resolution(resolution), seed=seed,
                               camera=camera, force=force)
    info = read_info(folder)
    typer.echo(f"{folder}: {info['frames']} frames of {info['scenario']} at "
               f"{info['resolution'][0]}x{info['resolution'][1]} ({info['notes']})")
