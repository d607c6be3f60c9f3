"""posgmc-fss/1 files: exact round trips, and one clear error per kind of bad file (file + JSON
path)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.errors import InputError
from posgmc.strategies.files import dump_strategy, parse_strategy, read_strategy, strategy_from_json
from posgmc.strategies.fss import FiniteStateStrategy, StrategyError

EXAMPLE = {  # the example of docs/strategies.md
    "format": "posgmc-fss/1", "player": "rover", "memory_size": 2, "initial_memory": 0,
    "observables": ["pos"],
    "rules": [
        {"memory": 0, "observation": {"pos": 0}, "action": {"via1": 0.7, "via2": 0.3},
         "update": {"via1": {"0": 1.0}, "via2": {"1": 1.0}}},
        {"memory": 1, "observation": {"pos": 0}, "action": {"via2": 1.0}},
    ],
}


def test_example_reads_into_arrays() -> None:
    f = strategy_from_json(EXAMPLE)
    assert (f.memory_size, f.num_observations, f.actions) == (2, 1, ("via1", "via2"))
    assert f.action[0, 0].tolist() == [0.7, 0.3]
    assert f.action[1, 0].tolist() == [0.0, 1.0]
    assert f.update[0, 0, 1].tolist() == [0.0, 1.0]
    assert f.update[1, 0, 1].tolist() == [0.0, 1.0]  # no update: the memory stays
    assert not f.is_deterministic


@st.composite
def strategies(draw: st.DrawFn) -> FiniteStateStrategy:
    k = draw(st.integers(1, 3))
    boolean = draw(st.booleans())
    num_obs = draw(st.integers(1, 2 if boolean else 4))
    num_act = draw(st.integers(1, 3))
    values = np.array(
        draw(st.lists(st.integers(0, 1) if boolean else st.integers(-5, 5), min_size=num_obs,
                      max_size=num_obs, unique=True)), dtype=np.int64)[:, None]
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    action = rng.random((k, num_obs, num_act)) * (rng.random((k, num_obs, num_act)) < 0.7)
    action[..., 0] += 1e-3
    action /= action.sum(axis=2, keepdims=True)
    action[rng.random((k, num_obs)) < 0.2] = 0.0  # some (memory, observation) without a rule
    update = rng.random((k, num_obs, num_act, k)) ** 3
    update /= update.sum(axis=3, keepdims=True)
    return FiniteStateStrategy.from_arrays(
        player="p", initial_memory=int(rng.integers(k)), observables=("o",),
        observation_values=values, actions=tuple(f"a{i}" for i in range(num_act)),
        action=action, update=update * (action[..., None] > 0),
        boolean=(True,) if boolean else (),
    )


def _rules(
    f: FiniteStateStrategy,
) -> dict[tuple[int, tuple[int, ...], str], tuple[float, tuple[float, ...]]]:
    """Every played (memory, observation, action) with its probability and update row."""
    out = {}
    for n, z, a in zip(*np.nonzero(f.action > 0)):
        key = (int(n), tuple(f.observation_values[z].tolist()), f.actions[a])
        out[key] = (float(f.action[n, z, a]), tuple(f.update[n, z, a].tolist()))
    return out


@settings(max_examples=60, deadline=None)
@given(strategies())
def test_round_trip_is_exact(f: FiniteStateStrategy) -> None:
    g = parse_strategy(dump_strategy(f))
    assert _rules(g) == _rules(f)  # bit-identical probabilities, whatever the numbering
    assert (g.memory_size, g.initial_memory) == (f.memory_size, f.initial_memory)
    if f.has_rule.any():  # a file without rules has no values to show an observable's type
        assert g.boolean == f.boolean
    assert dump_strategy(g) == dump_strategy(f)


def test_boolean_observables_are_written_as_json_booleans() -> None:
    doc = {**EXAMPLE, "observables": ["spoofed"],
           "rules": [{"memory": 0, "observation": {"spoofed": True}, "action": {"hold": 1.0}}]}
    f = strategy_from_json(doc)
    assert f.observation_values.tolist() == [[1]] and f.boolean == (True,)
    assert json.loads(dump_strategy(f))["rules"][0]["observation"] == {"spoofed": True}


def test_read_and_write_files(tmp_path) -> None:
    from posgmc.strategies.files import write_strategy

    f = strategy_from_json(EXAMPLE)
    path = tmp_path / "s.json"
    write_strategy(f, path)
    g = read_strategy(path)
    assert g.source == str(path)
    assert np.array_equal(g.action, f.action) and np.array_equal(g.update, f.update)


def _rule(**changes: object) -> dict:
    return {**EXAMPLE, "rules": [{**EXAMPLE["rules"][0], **changes}, EXAMPLE["rules"][1]]}


@pytest.mark.parametrize(
    ("doc", "path", "words"),
    [
        ({**EXAMPLE, "format": "fss/2"}, "format", "format must be 'posgmc-fss/1'"),
        ({k: v for k, v in EXAMPLE.items() if k != "player"}, "player", "is missing"),
        ({**EXAMPLE, "memory_size": 0}, "memory_size", "at least 1"),
        ({**EXAMPLE, "initial_memory": 2}, "initial_memory", "is not a memory node"),
        ({**EXAMPLE, "colour": 1}, "colour", "unknown field"),
        (_rule(memory=2), "rules[0].memory", "memory 2 is not a memory node (0..1)"),
        (_rule(memory="0"), "rules[0].memory", "must be an integer"),
        (
            _rule(action={"via1": 0.7, "via2": 0.2}),
            "rules[0].action",
            "sum to 0.8999999999999999, not 1",
        ),
        (
            _rule(action={"via1": 1.5, "via2": -0.5}),
            "rules[0].action.via1",
            "a probability must be a number in [0, 1]",
        ),
        (
            _rule(update={"via3": {"0": 1.0}}),
            "rules[0].update.via3",
            "which the rule does not play",
        ),
        (_rule(update={"via1": {"7": 1.0}}), "rules[0].update.via1.7", "is not a memory node"),
        (_rule(observation={"pos": 0.5}), "rules[0].observation.pos", "an integer or true/false"),
        (_rule(observation={"x": 0}), "rules[0].observation.x", "not one of the observables"),
        (
            {**EXAMPLE, "rules": [EXAMPLE["rules"][0], EXAMPLE["rules"][0]]},
            "rules[1]",
            "a second rule for memory 0",
        ),
    ],
)
def test_bad_documents_name_file_and_json_path(doc: dict, path: str, words: str) -> None:
    with pytest.raises(StrategyError) as info:
        strategy_from_json(doc, file="s.json")
    assert info.value.path == path and info.value.file == "s.json"
    assert words in info.value.message
    assert info.value.message.startswith(f"s.json: {path}: ")


def test_malformed_json_has_line_and_column() -> None:
    with pytest.raises(InputError) as info:
        parse_strategy('{"format": "posgmc-fss/1",\n "player": }', file="s.json")
    e = info.value
    assert (e.span.file, e.span.line, e.span.column) == ("s.json", 2, 12)
    assert "not valid JSON" in e.render()


def test_missing_file_is_an_input_error(tmp_path) -> None:
    with pytest.raises(InputError, match="no such file"):
        read_strategy(tmp_path / "nope.json")


BIG = "1" + "0" * 5000  # 5001 digits: beyond Python's 4300-digit limit on int()


@pytest.mark.parametrize(
    "text, path, words",
    [
        # a probability written with 5001 digits (an integer: json would call int() on it)
        (json.dumps(EXAMPLE).replace('"via2": 1.0}', f'"via2": {BIG}}}'), "rules[1].action.via2",
         "a probability must be a number in [0, 1], got 1000000000000000000000000000000000000000"
         "... (5001 characters)"),
        (json.dumps(EXAMPLE).replace('"pos": 0}, "action": {"via2"', '"pos": 10000000000000000'
                                     '00000000000000}, "action": {"via2"'),
         "rules[1].observation.pos",
         "the value of 'pos' 1000000000000000000000000000000 is beyond 64-bit integers"),
        (json.dumps(EXAMPLE).replace('"memory": 1,', f'"memory": {BIG},'), "rules[1].memory",
         "memory 1000000000000000000000000000000000000000... (5001 characters) is beyond 64-bit"),
        (json.dumps(EXAMPLE).replace('"memory_size": 2', f'"memory_size": {BIG}'), "memory_size",
         "is beyond 64-bit integers"),
        (json.dumps(EXAMPLE).replace('"memory_size": 2', '"memory_size": 10000000000'),
         "memory_size", "memory_size 10000000000 is more than the largest supported, 2147483647"),
        (json.dumps(EXAMPLE).replace('{"0": 1.0}', f'{{"{BIG}": 1.0}}'),
         "rules[0].update.via1.1000000000000000000000000000000000000000...(5001 characters)",
         "is not a memory node (0..1)"),
    ],
)
def test_absurd_numbers_are_positioned_errors(text: str, path: str, words: str) -> None:
    with pytest.raises(StrategyError) as info:
        parse_strategy(text, file="s.json")
    assert info.value.path == path and info.value.file == "s.json"
    assert words in info.value.message
    assert len(info.value.message) < 300  # the huge number is cut, not echoed
