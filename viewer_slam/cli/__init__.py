"""The ``viewslam`` command line: thin wrappers that parse options and call the library.

Bad input of any kind ends in one line on stderr and exit code 2, never a traceback; an
unexpected error ends in one line naming a log file that holds the full traceback. Each
command imports the heavy libraries (Rerun, OpenCV, Open3D, GTSAM) only when it runs and
only those it uses, so ``viewslam --help`` and the light commands start at once.
"""

import errno
import logging
import os
import sys
import tempfile
import time
import traceback
import warnings
from pathlib import Path
from typing import Protocol, cast

from .. import stopping
from ..errors import InputError, Interrupted
from ..terminal import degrade_to_ascii

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130
# Rerun's Rust side logs its own errors on stderr (e.g. the file sink's "No space left on
# device"); the command reports them in its one line instead.
RUST_LOG_DEFAULT = "warn,re_log_encoding=off,re_sdk=off,re_grpc_client=off"


# NumPy's floating-point warnings (a NaN compared, a division by zero, a mean of nothing): the code
# handles such values where it uses them, and on stderr the warnings would only be noise.
NUMPY_FLOAT_WARNINGS = (r"(invalid value|divide by zero|overflow|underflow) encountered|Mean of empty slice|"
                        r"Degrees of freedom <= 0")
STDOUT_FD = 1
# An error writing with no file name is the output stream's: full, closed pipe, closed descriptor.
STDOUT_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EIO, errno.EFBIG, errno.EPIPE, errno.EBADF)


def main(argv: list[str] | None = None) -> int:
    """Run the command line ``argv``; the exit code (Ctrl-C, SIGTERM and SIGHUP: 130, one line; a
    second stop signal while the first is honoured is absorbed, a third aborts: ``stopping.py``)."""
    with stopping.installed():
        try:
            return _run(argv)
        except Interrupted:  # a third stop signal while the line about the first was being written
            return EXIT_INTERRUPTED


def _run(argv: list[str] | None) -> int:
    os.environ.setdefault("RUST_LOG", RUST_LOG_DEFAULT)
    _guard_closed_stdout()
    for stream in (sys.stdout, sys.stderr):
        degrade_to_ascii(stream)
    logging.basicConfig(format="viewslam: warning: %(message)s", level=logging.WARNING)
    warnings.filterwarnings("ignore", category=RuntimeWarning, message=NUMPY_FLOAT_WARNINGS)
    try:  # everything, imports included, runs inside: Ctrl-C at any moment is one line
        import typer  # noqa: F401  (loaded first: the except clauses below look its exceptions up)

        from . import benchmark, datasets, diff, evaluate, pipelines, record, study, synth, view  # noqa: F401  (register commands)
        from .app import app

        result = app(args=argv, prog_name="viewslam", standalone_mode=False)
        if sys.stdout is not None:
            sys.stdout.flush()  # here, not at exit: a stdout that cannot take the output is one line
    except InputError as error:
        _error_line(f"viewslam: error: {error}")
        return EXIT_BAD_INPUT
    except _typer_exception("Abort"):
        return _interrupted()
    except _typer_exception("TyperException") as error:  # usage errors: unknown option, missing argument
        usage_error = cast(_UsageError, error)
        if not usage_error.format_message():  # bare `viewslam`: help was printed
            return 0
        context = getattr(error, "ctx", None)
        command = context.command_path if context is not None else "viewslam"
        _error_line(f"{command}: error: {usage_error.format_message()}")
        return EXIT_BAD_INPUT
    except (Interrupted, KeyboardInterrupt):
        return _interrupted()
    except BrokenPipeError as error:  # `viewslam ... | head -c1`: the reader left before the output ended
        return _stdout_error(error)
    except SystemExit as exit:
        if isinstance(exit.__context__, BrokenPipeError):  # typer turns a closed pipe into a silent exit 1
            return _stdout_error(exit.__context__)
        raise
    except Exception as error:
        if _raised_by_an_interrupt(error):
            return _interrupted()
        if isinstance(error, OSError) and error.filename is not None:
            # a path the system refuses (a name too long, a folder under a file, no permission)
            _error_line(f"viewslam: error: {error.filename}: {error.strerror}")
            return EXIT_BAD_INPUT
        if isinstance(error, OSError) and error.errno in STDOUT_ERRNOS:
            # files are written under names that their errors carry: what has none is the output stream
            return _stdout_error(error)
        # a bug: one line, and the traceback where it can be sent to us
        print(f"viewslam: internal error: {type(error).__name__}: {' '.join(str(error).split())}"
              f"{_traceback_note(error)}", file=sys.stderr)
        return 1
    return result if isinstance(result, int) else 0


def _error_line(text: str) -> None:
    """``text`` as one line on stderr: line breaks inside it (a path's, a server's message) are
    shown escaped, as ``\\n``."""
    print(text.replace("\r", "\\r").replace("\n", "\\n"), file=sys.stderr)


def _stdout_error(error: OSError) -> int:
    """The one line for a stdout that cannot take the output (a full disk, a closed pipe or descriptor)."""
    _drop_stdout()
    print(f"viewslam: error: stdout: cannot write: {error.strerror}", file=sys.stderr)
    return EXIT_BAD_INPUT


class _ClosedStdout:
    """Stands in for a stdout the command was started without (``>&-``): a write fails as it would on
    the closed descriptor, so output that cannot go anywhere is an error, not silently dropped."""

    def write(self, text: str) -> int:
        raise OSError(errno.EBADF, os.strerror(errno.EBADF))

    def flush(self) -> None:
        pass

    def fileno(self) -> int:
        return STDOUT_FD

    def isatty(self) -> bool:
        return False


def _guard_closed_stdout() -> None:
    """With descriptor 1 closed, hold it with /dev/null, so that no file the command opens gets it
    (and receives what a library prints), and make Python's own writes to stdout fail."""
    if sys.stdout is not None:
        return
    os.dup2(os.open(os.devnull, os.O_WRONLY), STDOUT_FD)
    sys.stdout = _ClosedStdout()


def _drop_stdout() -> None:
    """Point stdout at /dev/null, so that what is still buffered does not fail again at exit."""
    if sys.stdout is not None:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())


def _interrupted() -> int:
    print("viewslam: interrupted", file=sys.stderr)
    return EXIT_INTERRUPTED


def _typer_exception(name: str) -> type[BaseException]:
    """typer's exception class ``name`` once typer is loaded (an ``except`` clause evaluates it only
    when an exception is being matched), else a class nothing raises."""
    typer = sys.modules.get("typer")
    return getattr(typer, name) if typer is not None else _Never


class _Never(Exception):
    pass


class _UsageError(Protocol):
    """What the command line reads of typer's usage errors (click's ``ClickException``)."""

    def format_message(self) -> str: ...


def _raised_by_an_interrupt(error: BaseException) -> bool:
    """Whether ``error`` wraps a Ctrl-C or stop signal: a compiled extension that is interrupted while
    it loads re-raises the signal's exception as ``ImportError: initialization failed`` (pybind11)."""
    seen: set[int] = set()
    link: BaseException | None = error
    while link is not None and id(link) not in seen:
        if isinstance(link, (Interrupted, KeyboardInterrupt)):
            return True
        seen.add(id(link))
        link = link.__cause__ or link.__context__
    return False


def _traceback_note(error: Exception) -> str:
    """Write the full traceback to a log file; ``"; full traceback in PATH"`` (or nothing if unwritable)."""
    text = "".join(traceback.format_exception(error))
    name = f"viewslam-crash-{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}.log"
    for folder in (os.environ.get("VIEWSLAM_LOG_DIR"), tempfile.gettempdir()):
        if not folder:
            continue
        path = Path(folder) / name
        try:
            path.write_text(f"viewslam {' '.join(sys.argv[1:])}\n{text}", errors="backslashreplace")
        except OSError:
            continue
        return f"; full traceback in {path}"
    return ""


def entry_point() -> None:
    code = main()
    stopping.ignore()  # the command has ended: a stop signal now must not kill the exit that reports it
    recording = sys.modules.get("viewer_slam.recording.rrd_file")
    if recording is not None:  # a recording whose sink stalled: leave without waiting for it, with this code
        recording.leave_if_abandoned(code)
    sys.exit(code)
