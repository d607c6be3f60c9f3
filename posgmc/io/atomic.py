"""Atomic file writing: a reader never sees a half-written file, and an error leaves no trace."""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from posgmc.errors import InputError


@contextlib.contextmanager
def atomic_open(
    path: str | os.PathLike[str], mode: str = "w", *, encoding: str | None = "utf-8"
) -> Iterator[IO[Any]]:
    """Open a temporary file beside ``path``; on success it replaces ``path``, on error it is
    removed.

    Raises:
        InputError: the file cannot be written (no such directory, no permission, disk full),
            naming ``path`` (never the temporary file).
    """
    target = Path(path)
    if not str(path) or target.name in ("", ".", ".."):
        raise InputError(f"cannot write {str(path)!r}: not a file name")
    if _is_special(target):
        # a device or pipe (/dev/stdout, /dev/null, a FIFO): write into it; never replace it
        try:
            with open(target, mode, encoding=None if "b" in mode else encoding) as handle:
                yield handle
        except OSError as e:
            raise InputError(f"cannot write {path}: {e.strerror or e}") from None
        return
    directory = target.parent if str(target.parent) else Path(".")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=directory)
    except OSError as e:
        if directory.is_dir():
            # the directory exists but takes no new file (/proc says "No such file or
            # directory" for /proc/version, which exists): say so, not only the errno's words
            raise InputError(f"cannot write {path}: no new file can be created in {directory} "
                             f"({e.strerror or e})",
                             hint="the file is replaced by a new one written beside it; give a "
                             "path in a writable directory") from None
        raise InputError(f"cannot write {path}: {e.strerror or e}") from None
    try:
        with os.fdopen(fd, mode, encoding=None if "b" in mode else encoding) as handle:
            # mkstemp creates the file 0600; give it the mode open() would have given it.
            os.fchmod(handle.fileno(), _mode_for(target))
            yield handle
        os.replace(tmp, target)
    except OSError as e:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise InputError(f"cannot write {path}: {e.strerror or e}") from None
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically."""
    with atomic_open(path) as handle:
        handle.write(text)


def _is_special(target: Path) -> bool:
    """Whether ``target`` exists and is not a regular file (a device, a FIFO, a socket)."""
    try:
        return not stat.S_ISREG(target.stat().st_mode) and not target.is_dir()
    except OSError:
        return False


def _mode_for(target: Path) -> int:
    """The permission bits of the file being replaced, or the default ones for a new file."""
    try:
        return target.stat().st_mode & 0o777
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask
