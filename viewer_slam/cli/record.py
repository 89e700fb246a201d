"""`viewslam record` and `viewslam view`."""

import subprocess
from pathlib import Path

import typer

from ..errors import InputError
from ..recording.viewer import viewer_binary
from .app import app
from .options import MAX_FRAMES_HELP, PIPELINE_HELP, SEED_MAX

EXIT_INTERRUPTED = 130


@app.command("record")
def record_command(
    sequence: str | None = typer.Argument(
        None, help="TUM folder, synthetic scenario or TUM sequence name; none: the built-in demo."),
    pipeline: list[str] = typer.Option(["both"], help=PIPELINE_HELP),
    out: Path | None = typer.Option(None, help="Recording to write (default recordings/<sequence>.rrd); "
                                              "NAME.json and NAME.<pipeline>.txt go beside it."),
    max_frames: int | None = typer.Option(None, min=1, help=MAX_FRAMES_HELP),
    stride: int = typer.Option(1, min=1, help="Use every K-th frame."),
    param: list[str] = typer.Option([], help="Pipeline parameter under its original name, KEY=VALUE."),
    config: Path | None = typer.Option(None, help="TOML file of parameters (flat, or one table per pipeline)."),
    seed: int = typer.Option(0, min=0, max=SEED_MAX, help="Seed of every random choice."),
    quiet: bool = typer.Option(False, "--quiet", help="No progress bar and no summary."),
    spawn: bool = typer.Option(False, "--spawn", help="Also stream live into a Rerun viewer."),
) -> int:
    """Run SLAM pipelines over SEQUENCE into a Rerun recording, with a report and trajectories."""
    from ..recording.console import print_summary
    from ..recording.session import RecordOptions, record

    result = record(RecordOptions(sequence=sequence, pipeline=",".join(pipeline), out=out, max_frames=max_frames,
                                  stride=stride, params=param, config=config, seed=seed, quiet=quiet,
                                  spawn=spawn))
    if not quiet:
        print_summary(result.report, result.written)
    return EXIT_INTERRUPTED if result.interrupted else 0


@app.command("view")
def view_command(recording: Path = typer.Argument(..., help="A .rrd file written by `viewslam record`.")) -> int:
    """Open RECORDING in the Rerun viewer that ships with rerun-sdk."""
    if not recording.is_file():
        raise InputError.at(recording, "no such recording" if not recording.exists() else "not a file")
    return subprocess.call([str(viewer_binary()), str(recording)])
