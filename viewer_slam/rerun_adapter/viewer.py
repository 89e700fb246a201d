"""The Rerun viewer: the binary that ships with rerun-sdk, whether a window can open, and the
viewer a recording is also streamed to live (``record --spawn`` or ``--connect ADDR``)."""

import os
import re
import socket
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar
from urllib.parse import urlsplit

from ..errors import InputError

LOCALHOST = "127.0.0.1"
# A started viewer that cannot open its window (no X server behind DISPLAY) exits within a
# tenth of a second: one still running after this long is taken as up.
VIEWER_START_S = 2.0
# How long `--connect` waits for the viewer at ADDR to accept a connection.
CONNECT_TIMEOUT_S = 3.0
# A flush into a viewer at --connect that has made no progress for this long: the viewer stopped
# taking the stream (it died while the connection was being made, or hangs).
VIEWER_STALL_S = 10.0
URL_SCHEMES = ("rerun", "rerun+http", "rerun+https")
# A plain-text HTTP/2 client's first bytes: the connection preface and an empty SETTINGS frame,
# which every gRPC server answers with a SETTINGS frame of its own.
HTTP2_GREETING = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n" + bytes([0, 0, 0, 4, 0, 0, 0, 0, 0])


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
    return (
        f"no display to open a window on (DISPLAY and WAYLAND_DISPLAY are unset); "
        f"`viewslam view {recording} --web` serves the viewer to a browser instead"
    )


def open_window(recording: Path) -> int:
    """Show ``recording`` in the bundled viewer's window until it is closed; its exit code.

    The viewer's own log lines (its warnings, a graphics stack that fails) are kept off
    stderr; a viewer that fails is one line with the reason it gave last, and one that fails
    at once, as it does when no window can open (a DISPLAY with no X server behind it), is
    an :class:`InputError` that names the browser alternative.
    """
    with tempfile.TemporaryFile() as log:
        started = time.monotonic()
        process = subprocess.Popen(
            [str(viewer_binary()), str(recording)], stdin=subprocess.DEVNULL, stdout=log, stderr=log
        )
        try:
            code = process.wait()
        finally:
            if process.poll() is None:  # stopped by a signal sent to this process alone
                process.terminate()
                process.wait()
        if code == 0:
            return 0
        log.seek(0)
        reason = _last_line(log.read().decode(errors="replace")) or f"exit code {code}"
    if time.monotonic() - started < VIEWER_START_S:
        raise InputError(
            f"{recording}: the viewer cannot open a window ({reason}); `viewslam view {recording} "
            f"--web` serves the viewer to a browser instead"
        )
    raise InputError(f"{recording}: the viewer ended with an error ({reason})")


def _last_line(text: str) -> str:
    """The last line a program wrote, without terminal colours or a Rust error's source location."""
    lines = [line.strip() for line in re.sub(r"\x1b\[[0-9;]*m", "", text).splitlines() if line.strip()]
    if not lines:
        return ""
    return re.sub(r"\s+at \S+\.rs:\d+:\s*", ": ", lines[-1]).removeprefix("Error: ")


def viewer_binary() -> Path:
    """The bundled `rerun` executable, found without relying on the venv's bin folder being on PATH."""
    import rerun_cli

    return Path(rerun_cli.__file__).with_name("rerun")


def proxy_url(host: str, port: int, scheme: str = "rerun+http") -> str:
    """The gRPC address of a Rerun server's message proxy, as viewers and SDKs name it."""
    return f"{scheme}://{f'[{host}]' if ':' in host else host}:{port}/proxy"


@dataclass(frozen=True)
class SpawnedViewer:
    """The bundled viewer, started for one recording as a client of the recording's own gRPC
    server on a free port of 127.0.0.1.

    The run serves and the viewer connects, not the other way round: no other viewer (one
    already on Rerun's default port) receives the recording, and the server never waits for
    its client, so a viewer that dies or hangs costs the run nothing.
    """

    recording: Path
    port: int = field(default_factory=free_port)
    stall_s: ClassVar[float | None] = None  # the server never holds the stream back

    def sink(self):
        import rerun as rr

        return rr.GrpcServerSink(LOCALHOST, self.port)

    def start(self) -> None:
        """Start the viewer (once the server is up) and see that it stays up; one line if not."""
        binary = viewer_binary()
        try:
            process = subprocess.Popen(
                [str(binary), "--connect", proxy_url(LOCALHOST, self.port)],
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                start_new_session=True,
            )
        except OSError as error:
            raise InputError(f"--spawn: cannot start the viewer {binary}: {error.strerror}") from None
        try:
            code = process.wait(VIEWER_START_S)
        except subprocess.TimeoutExpired:
            return
        raise InputError(
            f"--spawn: the viewer exited at once (exit code {code}), as it does when no window can "
            f"open; `viewslam view {self.recording} --web` serves the viewer to a browser instead"
        )


@dataclass(frozen=True)
class ConnectedViewer:
    """A viewer already running at ``address`` (``--connect``), streamed to as a gRPC client."""

    address: str
    url: str
    stall_s: ClassVar[float | None] = VIEWER_STALL_S

    def sink(self):
        import rerun as rr

        return rr.GrpcSink(self.url)

    def start(self) -> None:
        """Nothing to start: :func:`connected_viewer` checked that the viewer accepts connections."""


LiveViewer = SpawnedViewer | ConnectedViewer


def live_viewer(spawn: bool, connect: str | None, recording: Path) -> LiveViewer | None:
    """The viewer ``record`` streams to besides the file (``--spawn`` or ``--connect``), checked
    before anything is written; None for neither."""
    if spawn and connect is not None:
        raise InputError("--spawn, --connect: give one: --spawn starts a viewer, --connect streams into a running one")
    if spawn:
        if not has_display():
            raise InputError(f"--spawn: {no_display_problem(recording)}")
        return SpawnedViewer(recording)
    if connect is not None:
        return connected_viewer(connect)
    return None


def connected_viewer(address: str) -> ConnectedViewer:
    """``--connect ADDR``: ``HOST:PORT`` or a viewer's ``rerun+http://HOST:PORT/proxy`` URL (also
    ``rerun://``, ``rerun+https://``) at which a gRPC server answers now.

    Rerun's gRPC client blocks the stream (and the process's main thread) on a server that
    accepts the connection but never answers, so one that does not answer an HTTP/2 greeting
    within CONNECT_TIMEOUT_S is refused before anything is written.
    """
    host, port, url = _parse_address(address)
    try:
        with socket.create_connection((host, port), timeout=CONNECT_TIMEOUT_S) as connection:
            if url.startswith("rerun+http:"):  # rerun:// and rerun+https:// speak TLS first
                connection.sendall(HTTP2_GREETING)
                if not connection.recv(1):
                    raise ConnectionResetError(0, "closed without answering")
    except TimeoutError:
        raise InputError(f"--connect {address}: no answer from a viewer there in {CONNECT_TIMEOUT_S:g} s") from None
    except OSError as error:
        reason = error.strerror or str(error) or type(error).__name__
        raise InputError(
            f"--connect {address}: no viewer accepts connections there ({reason}); start one "
            f"with `rerun`, or use --spawn"
        ) from None
    return ConnectedViewer(address, url)


def _parse_address(address: str) -> tuple[str, int, str]:
    """(host, port, gRPC URL) of ``--connect ADDR``; one line naming what is wrong with it."""
    problem = f"--connect {address}: not a viewer address; give HOST:PORT or rerun+http://HOST:PORT/proxy"
    with_scheme = "://" in address
    try:
        parts = urlsplit(address if with_scheme else f"//{address}")
        port = parts.port
    except ValueError:
        raise InputError(problem) from None
    if with_scheme and (parts.scheme not in URL_SCHEMES or parts.path != "/proxy"):
        raise InputError(problem)
    if not parts.hostname or port is None or port == 0 or (not with_scheme and (parts.path or parts.query)):
        raise InputError(problem)
    return parts.hostname, port, address if with_scheme else proxy_url(parts.hostname, port)
