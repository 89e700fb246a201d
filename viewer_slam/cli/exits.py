"""How a command ends: every error mapped to its exit code and one line on stderr.

Bad input of any kind: one line and exit code 2; a stop signal: one line and 130; a stdout
that cannot take the output: one line and 2; an unexpected error: one line naming a log file
that holds the full traceback, and 1.
"""

import errno
import sys
from typing import cast

from ..crash_log import crash_log_note
from ..errors import InputError, Interrupted
from ..stopping import raised_by_a_stop
from ..terminal import drop_stdout
from .typer_errors import UsageError, typer_exception

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130
# An error writing with no file name is the output stream's: full, closed pipe, closed descriptor.
STDOUT_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EIO, errno.EFBIG, errno.EPIPE, errno.EBADF)


def exit_code(error: BaseException) -> int:
    """The exit code of a command that raised ``error``, its one line written on stderr (a
    ``SystemExit`` that is no closed pipe's is raised again)."""
    if isinstance(error, InputError):
        _error_line(f"viewslam: error: {error}")
        return EXIT_BAD_INPUT
    if isinstance(error, typer_exception("Abort")):
        return _interrupted()
    if isinstance(error, typer_exception("TyperException")):  # usage errors: unknown option, missing argument
        usage_error = cast(UsageError, error)
        if not usage_error.format_message():  # bare `viewslam`: help was printed
            return 0
        context = getattr(error, "ctx", None)
        command = context.command_path if context is not None else "viewslam"
        _error_line(f"{command}: error: {usage_error.format_message()}")
        return EXIT_BAD_INPUT
    if isinstance(error, (Interrupted, KeyboardInterrupt)):
        return _interrupted()
    if isinstance(error, BrokenPipeError):  # `viewslam ... | head -c1`: the reader left before the output ended
        return _stdout_error(error)
    if isinstance(error, SystemExit):
        if isinstance(error.__context__, BrokenPipeError):  # typer turns a closed pipe into a silent exit 1
            return _stdout_error(error.__context__)
        raise error
    if raised_by_a_stop(error):
        return _interrupted()
    if isinstance(error, OSError) and error.filename is not None:
        # a path the system refuses (a name too long, a folder under a file, no permission)
        _error_line(f"viewslam: error: {error.filename}: {error.strerror}")
        return EXIT_BAD_INPUT
    if isinstance(error, OSError) and error.errno in STDOUT_ERRNOS:
        # files are written under names that their errors carry: what has none is the output stream
        return _stdout_error(error)
    # a bug: one line, and the traceback where it can be sent to us
    print(
        f"viewslam: internal error: {type(error).__name__}: {' '.join(str(error).split())}{crash_log_note(error)}",
        file=sys.stderr,
    )
    return 1


def _error_line(text: str) -> None:
    """``text`` as one line on stderr: line breaks inside it (a path's, a server's message) are
    shown escaped, as ``\\n``."""
    print(text.replace("\r", "\\r").replace("\n", "\\n"), file=sys.stderr)


def _stdout_error(error: OSError) -> int:
    """The one line for a stdout that cannot take the output (a full disk, a closed pipe or descriptor)."""
    drop_stdout()
    print(f"viewslam: error: stdout: cannot write: {error.strerror}", file=sys.stderr)
    return EXIT_BAD_INPUT


def _interrupted() -> int:
    print("viewslam: interrupted", file=sys.stderr)
    return EXIT_INTERRUPTED
