"""JSON and TOML files read within bounds: every failure one :class:`InputError` naming the file.

Every structured file viewslam reads (``camera.json``, ``--config`` TOML, the reports and
results given to ``diff``, a benchmark's cache) goes through here, so no file can make a
reader recurse without end, hold memory without limit, or raise anything but the one-line
error: a file larger than its kind ever is, text that is not UTF-8, a syntax error, a number
too long to convert, or values nested deeper than any of viewslam's files nest are refused
before a caller looks inside. What the values mean (types, ranges) the callers check.
"""

import json
import os
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .errors import InputError

MAX_DEPTH = 32
"""Levels of nesting: viewslam's deepest file (a report) nests 6."""
MAX_BYTES = 256 * 2**20
"""The largest file read: a report of a long sequence is a few MB."""


def read_json(path: Path, what: str, max_bytes: int = MAX_BYTES) -> Any:
    """The JSON value in ``path``, ``what`` naming the kind of file in errors."""
    return _read_document(Path(path), what, max_bytes, json.loads, "JSON")


def read_toml(path: Path, what: str, max_bytes: int = MAX_BYTES) -> dict[str, Any]:
    """The TOML document in ``path``, ``what`` naming the kind of file in errors."""
    data: dict[str, Any] = _read_document(Path(path), what, max_bytes, tomllib.loads, "TOML")
    return data


def _read_document(path: Path, what: str, max_bytes: int, parse: Callable[[str], Any], language: str) -> Any:
    """``parse`` of the file's text, bounded in size and depth; every failure an :class:`InputError`."""
    text = _read_text(path, what, max_bytes)
    try:
        data = parse(text)
    except RecursionError:
        raise _error(path, what, f"nested more than {MAX_DEPTH} levels deep") from None
    except ValueError as error:  # a decoding error, or an integer too long to convert
        raise _error(path, what, f"not valid {language}: {' '.join(str(error).split())}") from None
    _check_depth(data, path, what)
    return data


def _read_text(path: Path, what: str, max_bytes: int) -> str:
    try:
        with open(path, "rb") as handle:
            size = os.fstat(handle.fileno()).st_size
            if size > max_bytes:
                raise _error(path, what, f"{size:,} bytes, more than such a file ever holds ({max_bytes:,})")
            data = handle.read(max_bytes + 1)
    except FileNotFoundError:
        raise _error(path, what, "no such file") from None
    except IsADirectoryError:
        raise _error(path, what, "is a folder, not a file") from None
    except OSError as error:
        raise _error(path, what, error.strerror or str(error)) from None
    if len(data) > max_bytes:  # a file that grew, or a device that reports no size
        raise _error(path, what, f"more than such a file ever holds ({max_bytes:,} bytes)")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise _error(path, what, f"not UTF-8 text (byte {error.start})") from None


def _check_depth(data: Any, path: Path, what: str) -> None:
    """Refuse values nested deeper than MAX_DEPTH, walked without recursion."""
    pending: list[tuple[Any, int]] = [(data, 1)]
    while pending:
        value, depth = pending.pop()
        children = value.values() if isinstance(value, dict) else value if isinstance(value, list) else ()
        for child in children:
            if isinstance(child, (dict, list)):
                if depth + 1 > MAX_DEPTH:
                    raise _error(path, what, f"nested more than {MAX_DEPTH} levels deep")
                pending.append((child, depth + 1))


def _error(path: Path, what: str, problem: str) -> InputError:
    return InputError.at(path, f"cannot read {what}: {problem}")
