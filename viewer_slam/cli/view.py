"""`viewslam view`: a recording in the Rerun viewer, native or served to a browser."""

import os
import socket
import subprocess
import sys
from pathlib import Path

import typer

from ..errors import InputError
from ..recording.viewer import viewer_binary
from .app import app

LOCALHOST = "127.0.0.1"


def has_display() -> bool:
    """Whether a native window can open: always off Linux, else with an X11 or Wayland display."""
    return not sys.platform.startswith("linux") or bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def free_port() -> int:
    """A port on 127.0.0.1 nothing listens on now (the OS's choice)."""
    with socket.socket() as probe:
        probe.bind((LOCALHOST, 0))
        return probe.getsockname()[1]


def web_viewer_command(recording: Path, web_port: int, grpc_port: int) -> list[str]:
    """Rerun serving its web viewer on ``web_port`` and the recording over gRPC on ``grpc_port``,
    both on 127.0.0.1 only."""
    return [str(viewer_binary()), "--web-viewer", "--bind", LOCALHOST, "--web-viewer-port", str(web_port),
            "--port", str(grpc_port), str(recording)]


@app.command("view")
def view_command(
    recording: Path = typer.Argument(..., help="A .rrd file written by `viewslam record`."),
    web: bool = typer.Option(False, "--web", help="Serve Rerun's web viewer on 127.0.0.1 and print its address "
                                                  "(for a machine with no display; Ctrl-C stops it)."),
) -> int:
    """Open RECORDING in the Rerun viewer that ships with rerun-sdk."""
    if not recording.is_file():
        raise InputError.at(recording, "no such recording" if not recording.exists() else "not a file")
    if not web:
        if not has_display():
            raise InputError(f"no display to open a window on (DISPLAY and WAYLAND_DISPLAY are unset); "
                             f"`viewslam view {recording} --web` serves the viewer to a browser instead")
        return subprocess.call([str(viewer_binary()), str(recording)])
    web_port, grpc_port = free_port(), free_port()
    print(f"serving {recording} at http://{LOCALHOST}:{web_port}/?url=rerun%2Bhttp%3A%2F%2F{LOCALHOST}%3A{grpc_port}"
          f"%2Fproxy (Ctrl-C stops)", flush=True)
    return subprocess.call(web_viewer_command(recording, web_port, grpc_port), stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL)
