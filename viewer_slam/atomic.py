"""Outputs that appear complete or not at all, and one writer per output at a time.

Every file is written under a temporary name beside its target (same folder, hence same
file system) and renamed onto it once complete, so a run that fails never leaves a
half-written file where the last good one was. A lock file beside the target keeps a
second run from writing the same outputs at the same time. Every write goes through
:func:`writing`, so a full disk (or a file-size limit, a folder removed underneath) is the
command's one line naming the output, never an error without a name that would be taken
for stdout's.
"""

import errno
import fcntl
import os
import tempfile
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

from .errors import InputError

_UMASK = os.umask(0)
os.umask(_UMASK)


@contextmanager
def writing(target: Path) -> Iterator[None]:
    """The guard around every write of ``target`` (a file, or a folder being filled): an
    :class:`OSError` inside is :class:`InputError` naming ``target``."""
    try:
        yield
    except OSError as error:
        raise InputError.at(target, f"cannot write: {error.strerror or error}") from None


def check_writable(target: Path) -> None:
    """Fail now, before any work, if ``target`` cannot be written (its folder is created): its
    name must be UTF-8 text (reports and recordings record it) and leave room for the temporary
    name it is written under."""
    target = Path(target)
    check_name(target)
    try:
        if target.is_dir():
            raise InputError.at(target, "is a folder, not a file name")
        target.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=target.parent):
            pass
        longest = len(os.fsencode(f".{target.name}.XXXXXXXX.part"))
        limit = os.pathconf(target.parent, "PC_NAME_MAX")
    except OSError as error:
        raise InputError.at(target, f"cannot write: {error.strerror or error}") from None
    if longest > limit:
        raise InputError.at(
            target,
            f"name too long: {len(os.fsencode(target.name))} bytes, and written under a "
            f"temporary name {longest - len(os.fsencode(target.name))} bytes longer; the file "
            f"system allows {limit}",
        )


def check_name(path: Path) -> None:
    """An output's name must be UTF-8 text: reports and recordings record it."""
    try:
        str(path).encode()
    except UnicodeEncodeError:
        raise InputError.at(
            str(path).encode(errors="surrogateescape").decode(errors="backslashreplace"), "the name is not UTF-8 text"
        ) from None


# The files of a TUM folder given as an input that a command reads.
_FOLDER_INPUTS = ("rgb.txt", "depth.txt", "groundtruth.txt", "accelerometer.txt", "camera.json")


def refuse_inputs_as_outputs(outputs: dict[Path, str], inputs: dict[Path, str]) -> None:
    """Fail now, before anything is written, if an output would replace an input of the same
    command: the same file (by inode, so a hard link or another spelling counts), or the same
    path when neither exists yet. ``outputs`` maps each path to the option that names it,
    ``inputs`` each input (a file, or a TUM folder whose listings count) to how it was given."""
    files = {}
    for path, given in inputs.items():
        path = Path(path)
        files[path] = given
        if path.is_dir():
            files |= {path / name: f"{given} ({name})" for name in _FOLDER_INPUTS}
    for output, option in outputs.items():
        for path, given in files.items():
            if _same_file(Path(output), path):
                raise InputError(
                    f"{option}: {output} is the input {given}; choose another name, an input is never overwritten"
                )


def _same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist (yet): the same path is the same file
        return os.path.abspath(a) == os.path.abspath(b)


class StagedFiles:
    """Temporary files beside their targets, renamed into place together by :meth:`commit`.

    Leaving the ``with`` block without a commit removes the temporary files, so the targets
    keep whatever they held before.
    """

    def __init__(self):
        self._staged: dict[Path, Path] = {}

    def path(self, target: Path) -> Path:
        """The temporary path that stands for ``target`` until the commit."""
        target = Path(target)
        if target not in self._staged:
            with writing(target):
                handle, name = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".part")
            os.fchmod(handle, 0o666 & ~_UMASK)  # as an ordinary new file, not mkstemp's owner-only mode
            os.close(handle)
            self._staged[target] = Path(name)
        return self._staged[target]

    def write(self, target: Path, write: Callable[[Path], object]) -> None:
        """``write`` to ``target``'s temporary file, guarded by :func:`writing`."""
        with writing(target):
            write(self.path(target))

    def discard(self, target: Path) -> None:
        """Forget ``target``: its temporary file is removed and it is not committed."""
        staged = self._staged.pop(Path(target), None)
        if staged is not None:
            staged.unlink(missing_ok=True)

    def commit(self) -> None:
        """Rename every temporary file onto its target, in the order they were staged."""
        for target, staged in list(self._staged.items()):
            with writing(target):
                os.replace(staged, target)
            del self._staged[target]

    def __enter__(self) -> "StagedFiles":
        return self

    def __exit__(self, *exc_info) -> None:
        for target in list(self._staged):
            self.discard(target)


def write_text(target: Path, text: str) -> None:
    """Write ``text`` to ``target`` through a temporary file renamed into place."""
    with StagedFiles() as staged:
        staged.write(target, lambda path: path.write_text(text))
        staged.commit()


def lock_path(target: Path) -> Path:
    return Path(target).with_name(f".{Path(target).name}.lock")


@contextmanager
def exclusive(targets: Iterable[Path], wait: bool = False) -> Iterator[None]:
    """Hold a lock per target for the block; :class:`InputError` if another run holds one, or
    with ``wait``, once it lets go."""
    held: list[tuple[Path, int]] = []
    try:
        for target in targets:
            held.append((lock_path(target), _lock(Path(target), wait)))
        yield
    finally:
        for path, handle in reversed(held):
            path.unlink(missing_ok=True)  # while still locked: a waiting run then re-checks the inode
            os.close(handle)


def _lock(target: Path, wait: bool = False) -> int:
    path = lock_path(target)
    while True:
        try:
            handle = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as error:
            raise InputError.at(target, f"cannot write: {error.strerror or error}") from None
        try:
            fcntl.flock(handle, fcntl.LOCK_EX if wait else fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as error:
            os.close(handle)
            if error.errno in (errno.EWOULDBLOCK, errno.EAGAIN):
                raise InputError.at(
                    target, "another viewslam run is writing this output; wait for it or choose another --out"
                ) from None
            raise
        try:
            same = os.stat(path).st_ino == os.fstat(handle).st_ino
        except FileNotFoundError:
            same = False
        if same:
            return handle
        os.close(handle)  # the previous holder removed the file between our open and flock: retry
