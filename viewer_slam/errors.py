"""The one exception type that the command line turns into a one-line message and exit code 2."""


class InputError(ValueError):
    """Bad user input: a file that cannot be read, a malformed line, an unknown option value.

    The message is a single line that names the file (and line number where there is one)
    and the problem, e.g. ``groundtruth.txt:12: expected 8 fields, found 7``.
    """

    @classmethod
    def at(cls, path, problem: str, line: int | None = None) -> "InputError":
        where = f"{path}:{line}" if line is not None else f"{path}"
        return cls(f"{where}: {problem}")


class Interrupted(BaseException):
    """Ctrl-C, SIGTERM or SIGHUP outside a run that stops cleanly on its own.

    Not a KeyboardInterrupt, which the command-line framework would swallow into a silent
    exit code: the command line turns it into one line and exit code 130.
    """
