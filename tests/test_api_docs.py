"""Every example of docs/api.md runs, from the repository's root, and its assertions hold."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "api.md"


def _examples() -> list[tuple[str, str]]:
    """(heading, code) of every python block, named by the section it stands in."""
    text = DOC.read_text(encoding="utf-8")
    out: list[tuple[str, str]] = []
    heading = "intro"
    for block in re.split(r"^(## .*)$", text, flags=re.M):
        if block.startswith("## "):
            heading = block[3:].strip()
            continue
        for code in re.findall(r"```python\n(.*?)```", block, flags=re.S):
            out.append((heading, code))
    return out


EXAMPLES = _examples()


def test_the_document_has_its_examples() -> None:
    assert len(EXAMPLES) == 9
    assert [h.split(".")[0] for h, _ in EXAMPLES] == [str(i) for i in range(1, 10)]


@pytest.mark.parametrize(("heading", "code"), EXAMPLES, ids=[h.split(".")[0] for h, _ in EXAMPLES])
def test_example_runs(heading: str, code: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)
    exec(compile(code, f"docs/api.md: {heading}", "exec"), {"__name__": "__example__"})  # noqa: S102
