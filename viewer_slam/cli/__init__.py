"""The ``viewslam`` command line: thin wrappers that parse options and call the library.

Bad input of any kind ends in one line on stderr and exit code 2, never a traceback.
"""

import sys

import typer

from ..errors import InputError
from . import benchmark, datasets, diff, evaluate, pipelines, record, synth  # noqa: F401  (register commands)
from .app import app

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130


def main(argv: list[str] | None = None) -> int:
    try:
        result = app(args=argv, prog_name="viewslam", standalone_mode=False)
    except InputError as error:
        print(f"viewslam: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except typer.TyperException as error:  # usage errors: unknown option, missing argument
        if not error.format_message():  # bare `viewslam`: help was printed
            return 0
        context = getattr(error, "ctx", None)
        command = context.command_path if context is not None else "viewslam"
        print(f"{command}: error: {error.format_message()}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except (typer.Abort, KeyboardInterrupt):
        print("viewslam: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    return result if isinstance(result, int) else 0


def entry_point() -> None:
    sys.exit(main())
