"""`viewslam view`: a recording in the Rerun viewer, native or served to a browser."""

import subprocess
from pathlib import Path

import typer

from ..errors import InputError
from ..rerun_adapter.viewer import LOCALHOST, free_port, has_display, no_display_problem, open_window, viewer_binary
from .app import app


def web_viewer_command(recording: Path, web_port: int, grpc_port: int) -> list[str]:
    """Rerun serving its web viewer on ``web_port`` and the recording over gRPC on ``grpc_port``,
    both on 127.0.0.1 only."""
    return [
        str(viewer_binary()),
        "--web-viewer",
        "--bind",
        LOCALHOST,
        "--web-viewer-port",
        str(web_port),
        "--port",
        str(grpc_port),
        str(recording),
    ]


@app.command("view")
def view_command(
    recording: Path = typer.Argument(..., help="A .rrd file written by `viewslam record`."),
    web: bool = typer.Option(
        False,
        "--web",
        help="Serve Rerun's web viewer on 127.0.0.1 and print its address "
        "(for a machine with no display; Ctrl-C stops it).",
    ),
) -> int:
    """Open RECORDING in the Rerun viewer that ships with rerun-sdk."""
    if not recording.is_file():
        raise InputError.at(recording, "no such recording" if not recording.exists() else "not a file")
    from ..rerun_adapter.rrd_file import has_footer  # Rerun's reader: only once there is a file to read

    if not has_footer(recording):
        raise InputError.at(
            recording, "not a complete Rerun recording (empty, truncated, or another kind of file: no RRD footer)"
        )
    if not web:
        if not has_display():
            raise InputError(no_display_problem(recording))
        return open_window(recording)
    web_port, grpc_port = free_port(), free_port()
    print(
        f"serving {recording} at http://{LOCALHOST}:{web_port}/?url=rerun%2Bhttp%3A%2F%2F{LOCALHOST}%3A{grpc_port}"
        f"%2Fproxy (Ctrl-C stops)",
        flush=True,
    )
    return subprocess.call(
        web_viewer_command(recording, web_port, grpc_port), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
