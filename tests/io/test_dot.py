"""DOT pictures: well-formed statements, every state drawn, owners by shape, a size limit."""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np
import pytest

from posgmc.errors import UnsupportedError
from posgmc.io.dot import dot_text, write_dot
from posgmc.model.explicit import make_model
from posgmc.syntax.ast import ModelType
from tests.io.helpers import tiny_dtmc, tiny_mdp, tiny_pomdp, tiny_posg, tiny_smg

# A DOT double-quoted string: no raw quote or newline inside, backslash escapes allowed.
_QUOTED = r'"(?:[^"\\\n]|\\.)*"'
_ATTRIBUTE = rf"\w+=(?:{_QUOTED}|[\w.]+)"
_ATTRIBUTES = rf"\[{_ATTRIBUTE}(?:, {_ATTRIBUTE})*\]"
_STATEMENT = re.compile(
    rf"  (?:(?:node|edge) {_ATTRIBUTES}|rankdir=LR|[sc]\d+ {_ATTRIBUTES}"
    rf"|[sc]\d+ -> s\d+ {_ATTRIBUTES}"
    rf"|s\d+ -> c\d+ {_ATTRIBUTES});"
)


def assert_well_formed(text: str) -> None:
    lines = text.splitlines()
    assert lines[0] == "digraph model {"
    assert lines[-1] == "}"
    for line in lines[1:-1]:
        assert _STATEMENT.fullmatch(line), line


@pytest.mark.parametrize(
    "build", [tiny_dtmc, tiny_mdp, tiny_pomdp, tiny_smg, tiny_posg], ids=lambda f: f.__name__
)
def test_well_formed_with_every_state(build: object) -> None:
    model = build()  # type: ignore[operator]
    text = dot_text(model)
    assert_well_formed(text)
    for s in range(model.num_states):
        assert re.search(rf"^  s{s} \[label=\"{s}(\\n|\")", text, re.MULTILINE)
    edges = re.findall(r" -> s\d+ \[label=", text)
    assert len(edges) == model.num_transitions


def test_mdp_picture() -> None:
    text = dot_text(tiny_mdp())
    # state 0: valuation, labels; initial, so a double border
    assert '  s0 [label="0\\n(x=0,b=0)\\ninit, two words", shape=circle, peripheries=2];' in text
    assert '  s0 -> c0 [arrowhead=none, label="a"];' in text
    assert '  c0 -> s2 [label="0.7"];' in text
    assert '  s1 -> c2 [arrowhead=none, label=""];' in text
    assert text.count("shape=point") == 4


def test_dtmc_edges_go_from_state_to_state() -> None:
    text = dot_text(tiny_dtmc())
    assert "shape=point" not in text
    assert '  s2 -> s0 [label="0.25"];' in text


def test_game_owners_are_shapes() -> None:
    text = dot_text(tiny_smg())
    assert '  s0 [label="0\\ninit", shape=circle, tooltip="player p1", peripheries=2];' in text
    assert '  s1 [label="1", shape=box, tooltip="player p2"];' in text


def test_observations_are_shown() -> None:
    assert '  s1 [label="1\\nz=1", shape=circle];' in dot_text(tiny_pomdp())
    text = dot_text(tiny_posg(same_observations=False))
    assert '  s2 [label="2\\nz_p1=1\\nz_p2=2\\ngoal", shape=circle, tooltip="player p1"];' in text


def test_quotes_and_backslashes_are_escaped() -> None:
    model = make_model(ModelType.DTMC, [0, 1], [[1.0]], labels={'say "hi" \\o/': [True]})
    text = dot_text(model)
    assert_well_formed(text)
    assert 'say \\"hi\\" \\\\o/' in text


def test_too_many_states_is_refused() -> None:
    n = 12
    chain = make_model(ModelType.DTMC, np.arange(n + 1), np.eye(n))
    with pytest.raises(UnsupportedError) as info:
        dot_text(chain, max_states=10)
    assert info.value.message == "the model has 12 states; DOT pictures are limited to 10"
    assert info.value.hint is not None and "max_states" in info.value.hint
    assert_well_formed(dot_text(chain, max_states=12))


def test_write_to_stream_and_file(tmp_path: Path) -> None:
    stream = io.StringIO()
    write_dot(tiny_mdp(), stream)
    path = tmp_path / "m.dot"
    write_dot(tiny_mdp(), path)
    assert path.read_text() == stream.getvalue() == dot_text(tiny_mdp())
