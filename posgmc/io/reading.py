"""Reading input text files with the errors a user can act on (one place for every input file)."""

from __future__ import annotations

import sys
from pathlib import Path

from posgmc.errors import InputError, SourceSpan, SourceText

__all__ = ["decode", "read_text"]


def read_text(path: str | Path) -> str:
    """The UTF-8 text of ``path``; ``-`` is standard input (as PRISM and Storm users expect).

    Raises:
        InputError: no such file, not UTF-8 (at the line and column of the first bad byte), or
            unreadable.
    """
    if str(path) == "-":
        buffer = getattr(sys.stdin, "buffer", None)
        return decode(buffer.read(), "-") if buffer is not None else sys.stdin.read()
    try:
        raw = Path(path).read_bytes()
    except FileNotFoundError:
        raise InputError(f"no such file: {path}") from None
    except OSError as e:
        raise InputError(f"cannot read {path}: {e.strerror}") from None
    return decode(raw, str(path))


def decode(raw: bytes, name: str) -> str:
    """``raw`` as UTF-8 text (universal newlines, as ``Path.read_text``).

    Raises:
        InputError: at ``name:line:col`` of the first byte that is not UTF-8 (``\n`` ends a
            line, as PRISM counts), with the line shown.
    """
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        line = raw.count(b"\n", 0, e.start) + 1
        line_start = raw.rfind(b"\n", 0, e.start) + 1
        column = len(raw[line_start : e.start].decode("utf-8", errors="replace")) + 1
        shown = raw.decode("utf-8", errors="replace").replace("\r\n", "\n")
        raise InputError(
            f"the file is not UTF-8 text ({e.reason}: byte 0x{raw[e.start]:02x} at offset "
            f"{e.start})",
            SourceSpan(line, column, file=name),
            hint="save the file as UTF-8 (e.g. iconv -f latin1 -t utf-8)",
            source=SourceText(shown, name),
        ) from None
    return text.replace("\r\n", "\n").replace("\r", "\n")
