"""The Rerun viewer binary that ships with rerun-sdk, and whether a window can open."""

import os
import socket
import sys
from pathlib import Path

LOCALHOST = "127.0.0.1"


def free_port() -> int:
    """A port on 127.0.0.1 nothing listens on now (the OS's choice)."""
    with socket.socket() as probe:
        probe.bind((LOCALHOST, 0))
        return probe.getsockname()[1]


def has_display() -> bool:
    """Whether a native window can open: always off Linux, else with an X11 or Wayland display."""
    return not sys.platform.startswith("linux") or bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def no_display_problem(recording) -> str:
    """The one line for a viewer window that cannot open, naming the browser alternative."""
    return (f"no display to open a window on (DISPLAY and WAYLAND_DISPLAY are unset); "
            f"`viewslam view {recording} --web` serves the viewer to a browser instead")


def viewer_binary() -> Path:
    """The bundled `rerun` executable, found without relying on the venv's bin folder being on PATH."""
    import rerun_cli

    return Path(rerun_cli.__file__).with_name("rerun")
