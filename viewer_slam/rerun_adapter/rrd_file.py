"""A Rerun stream saved to an ``.rrd`` file, with the write errors Rerun's file sink hides.

The file sink reports a failed write (a full disk, a file-size limit) only when flushed, and
only if its writer thread is still there to answer: once that thread has died on the error,
a flush queued behind it waits forever (Rerun 0.41), and so would the process at exit,
which flushes every stream again. So the flush runs on a thread of its own while the file is
watched: a file that stops growing while there is no room left for it is a stalled sink.
The stream is then abandoned: kept referenced so that it is never dropped (dropping joins
the dead writer), and the process leaves through ``os._exit`` once everything else it
writes is done, without Rerun's exit-time flush.

A viewer the stream also goes to can hold the file back the same way: the stream feeds all
its sinks from one thread, which waits on a gRPC client whose queue is full (a viewer at
``--connect`` that died while the connection was being made). Such a flush is stalled once
the file has not grown for the viewer's ``stall_s``. A viewer that ``--spawn`` starts is a
client of the stream's own server instead, which never waits.
"""

import atexit
import contextlib
import os
import resource
import shutil
import sys
import threading
import time
import warnings
from pathlib import Path

import rerun as rr
import rerun.blueprint as rrb

from ..errors import InputError
from .viewer import ConnectedViewer, LiveViewer

# Fewer, larger chunks than Rerun's default 200 ms tick: every chunk carries a schema.
BATCHER = rr.ChunkBatcherConfig(flush_tick=1.0, flush_num_bytes=4 * 2**20)
# Less free space than this after the file sink failed means the disk was full.
FULL_DISK_BYTES = 1 << 20
# Less free space than this before the file is opened: Rerun's first write (the header and the
# blueprint) could block forever on the full disk, before any watch can start.
START_BYTES = 256 << 10
# A flush whose file has not grown for this long, with no room left, has stalled.
STALL_S = 3.0
POLL_S = 0.2
# The exit status of a process whose recording could not be written.
NOT_WRITTEN_EXIT = 2

_abandoned: list[rr.RecordingStream] = []


class RecordingFile:
    """A Rerun stream saved to ``path``, and streamed live to ``viewer`` if any; ``target`` names it in errors.

    :meth:`close` flushes, and ``error`` then says what went wrong, or is None when the file
    is complete (it ends with the RRD footer that readers need).
    """

    def __init__(
        self,
        path: Path,
        target: Path,
        blueprint: rrb.Blueprint,
        viewer: LiveViewer | None = None,
        application: str = "viewslam",
    ):
        self.path = path
        self.viewer = viewer
        self.error: str | None = None
        self.stream = rr.RecordingStream(application, batcher_config=BATCHER)
        rr.set_log_time_enabled(False, recording=self.stream)  # the dataset's time is the one that matters
        free = shutil.disk_usage(path.parent).free
        if free < START_BYTES:
            raise InputError.at(
                target,
                f"cannot write the recording: no space left on device ({free:,} bytes "
                f"free, {START_BYTES:,} needed to start)",
            )
        try:
            if viewer is None:
                self.stream.save(path, default_blueprint=blueprint)
            else:
                self.stream.set_sinks(rr.FileSink(path), viewer.sink(), default_blueprint=blueprint)
        except RuntimeError as error:
            raise InputError.at(target, f"cannot write the recording: {disk_problem(path, error)}") from None
        if viewer is not None:
            try:
                viewer.start()
            except InputError:
                self.stream.disconnect()
                raise

    def close(self) -> None:
        """Flush and close the stream; ``error`` then says what went wrong (None: the file is complete).

        A flush error with the file complete is the viewer's (it went away), not the recording's.
        """
        stall_s = self.viewer.stall_s if self.viewer is not None else None
        closed, error = _close_watched(self.stream, self.path, stall_s)
        complete = has_footer(self.path)
        if not closed:
            _abandon(self.stream)
            if not complete:
                self.error = self._stall_problem()
            return
        if error is not None and not (self.viewer is not None and complete):  # else the viewer's stream failed
            self.error = disk_problem(self.path, error)
        elif not complete:
            self.error = disk_problem(self.path, None)

    def _stall_problem(self) -> str:
        """Why closing stalled: a viewer at --connect that stopped taking the stream, or the disk."""
        if isinstance(self.viewer, ConnectedViewer) and _room_problem(self.path) is None:
            return (
                f"the viewer at {self.viewer.address} stopped taking the stream ({self.viewer.stall_s:g} s "
                f"without progress)"
            )
        return disk_problem(self.path, None)


def _close_watched(
    stream: rr.RecordingStream, path: Path, stall_s: float | None = None
) -> tuple[bool, RuntimeError | None]:
    """Flush and disconnect ``stream``: (False, None) when it stalled, else (True, the flush's error or None).

    It has stalled when the file has not grown for STALL_S with no room left for it, or, with
    ``stall_s`` (a viewer the stream also goes to), for ``stall_s`` whatever the room.
    """
    finished = threading.Event()
    errors: list[RuntimeError] = []

    def close() -> None:
        try:
            stream.flush()
        except RuntimeError as error:
            errors.append(error)
        try:
            stream.disconnect()  # the file sink writes the footer readers need
        finally:
            finished.set()

    threading.Thread(target=close, name="rrd-close", daemon=True).start()
    size, grown_at = -1, time.monotonic()
    while not finished.wait(POLL_S):  # the main thread stays free for Ctrl-C and SIGTERM
        current = _size(path)
        if current != size:
            size, grown_at = current, time.monotonic()
            continue
        still = time.monotonic() - grown_at
        if (still > STALL_S and _room_problem(path) is not None) or (stall_s is not None and still > stall_s):
            return False, None
    return True, errors[0] if errors else None


def _abandon(stream: rr.RecordingStream) -> None:
    _abandoned.append(stream)
    if len(_abandoned) == 1:
        rr.unregister_shutdown()
        atexit.register(_exit_now)  # runs before any exit handler registered earlier


def _exit_now() -> None:
    leave_if_abandoned(NOT_WRITTEN_EXIT)


def leave_if_abandoned(code: int) -> None:
    """End the process now with ``code`` if a stream was abandoned: the interpreter's own exit
    would drop it, which waits forever on the sink that stalled."""
    if not _abandoned:
        return
    for output in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError, AttributeError):  # closed, or no stream at all
            output.flush()
    os._exit(code)


def _size(path: Path) -> int:
    try:
        return path.stat().st_size
    except OSError:
        return -1


def _room_problem(path: Path) -> str | None:
    """No space left on the file's disk, or the file at the process's file-size limit: which."""
    free = shutil.disk_usage(path.parent).free
    if free < FULL_DISK_BYTES:
        return f"no space left on device ({free:,} bytes free)"
    limit, _ = resource.getrlimit(resource.RLIMIT_FSIZE)
    if limit != resource.RLIM_INFINITY and _size(path) >= limit:
        return f"the file reached the process's file-size limit ({limit:,} bytes)"
    return None


def has_footer(path: Path) -> bool:
    """Whether ``path`` is a complete RRD file: it opens and ends with the footer readers need."""
    from rerun.chunk import RrdReader

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a file without footer opens with a warning
        try:
            RrdReader(path)
        except (Warning, RuntimeError, OSError):
            return False
    return True


def disk_problem(path: Path, error: Exception | None) -> str:
    """What most likely stopped the file sink."""
    return _room_problem(path) or (
        f"the file sink failed ({error})" if error is not None else "the recording is incomplete (no footer)"
    )
