"""The ``viewslam`` command line: thin wrappers that parse options and call the library.

Bad input of any kind ends in one line on stderr and exit code 2, never a traceback; an
unexpected error ends in one line naming a log file that holds the full traceback. Each
command imports the heavy libraries (Rerun, OpenCV, Open3D, GTSAM) only when it runs and
only those it uses, so ``viewslam --help`` and the light commands start at once.
"""

import logging
import os
import sys
import warnings

from .. import stopping
from ..errors import Interrupted
from ..terminal import degrade_to_ascii, guard_closed_stdout
from .exits import EXIT_INTERRUPTED, exit_code

# Rerun's Rust side logs its own errors on stderr (e.g. the file sink's "No space left on
# device"); the command reports them in its one line instead.
RUST_LOG_DEFAULT = "warn,re_log_encoding=off,re_sdk=off,re_grpc_client=off"


# NumPy's floating-point warnings (a NaN compared, a division by zero, a mean of nothing): the code
# handles such values where it uses them, and on stderr the warnings would only be noise.
NUMPY_FLOAT_WARNINGS = (
    r"(invalid value|divide by zero|overflow|underflow) encountered|Mean of empty slice|"
    r"Degrees of freedom <= 0"
)


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
    guard_closed_stdout()
    for stream in (sys.stdout, sys.stderr):
        degrade_to_ascii(stream)
    logging.basicConfig(format="viewslam: warning: %(message)s", level=logging.WARNING)
    warnings.filterwarnings("ignore", category=RuntimeWarning, message=NUMPY_FLOAT_WARNINGS)
    try:  # everything, imports included, runs inside: Ctrl-C at any moment is one line
        import typer  # noqa: F401  (loaded first: exit_code looks its exceptions up)

        from . import benchmark, diff, download, evaluate, pipelines, record, sequences, study, synth, view  # noqa: F401  (register commands)
        from .app import app

        result = app(args=argv, prog_name="viewslam", standalone_mode=False)
        if sys.stdout is not None:
            sys.stdout.flush()  # here, not at exit: a stdout that cannot take the output is one line
    except (Exception, KeyboardInterrupt, SystemExit, Interrupted) as error:
        return exit_code(error)
    return result if isinstance(result, int) else 0


def entry_point() -> None:
    code = main()
    stopping.ignore()  # the command has ended: a stop signal now must not kill the exit that reports it
    recording = sys.modules.get("viewer_slam.rerun_adapter.rrd_file")
    if recording is not None:  # a recording whose sink stalled: leave without waiting for it, with this code
        recording.leave_if_abandoned(code)
    sys.exit(code)
