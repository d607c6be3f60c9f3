"""Generated blocks in the READMEs: the text between ``<!-- NAME -->`` and
``<!-- NAME: end -->`` is what a benchmark script prints, rewritten by that script, so that a
README table cannot drift from its command."""

from __future__ import annotations

from pathlib import Path


def replace_block(text: str, name: str, block: str, end: str | None = None) -> str:
    """``text`` with the block ``name`` replaced by ``block``.

    Raises:
        SystemExit: the README has no such block (a script must not guess where a table goes).
    """
    begin, finish = f"<!-- {name} -->", end or f"<!-- {name}: end -->"
    try:
        i = text.index(begin) + len(begin)
        j = text.index(finish, i)
    except ValueError:
        raise SystemExit(f"no block '{begin}' ... '{finish}' to rewrite") from None
    return text[:i] + "\n" + block + "\n" + text[j:]


def rewrite_block(readme: Path, name: str, block: str) -> bool:
    """Rewrite the block ``name`` of ``readme``; whether it changed. The README is read here,
    after the (long) run that made ``block``, so that edits made meanwhile stay."""
    text = readme.read_text()
    new = replace_block(text, name, block)
    if new != text:
        readme.write_text(new)
    return new != text
