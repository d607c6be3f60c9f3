"""Reading input text files with the errors a user can act on (one place for every input file)."""

from __future__ import annotations

import sys
from pathlib import Path

from posgmc.errors import InputError

__all__ = ["read_text"]


def read_text(path: str | Path) -> str:
    """The UTF-8 text of ``path``; ``-`` is standard input (as PRISM and Storm users expect).

    Raises:
        InputError: no such file, not UTF-8 (with the byte offset), or unreadable.
    """
    if str(path) == "-":
        return sys.stdin.read()
    try:
        return Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"no such file: {path}") from None
    except UnicodeDecodeError as e:
        raise InputError(f"{path} is not UTF-8 text ({e.reason} at byte {e.start})") from None
    except OSError as e:
        raise InputError(f"cannot read {path}: {e.strerror}") from None
