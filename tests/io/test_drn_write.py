"""Writing DRN: read(write(m)) == m for every model type, exact numbers, atomic files."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc import api
from posgmc.errors import InputError, UnsupportedError
from posgmc.io._text import format_values
from posgmc.io.drn import drn_text, parse_drn, read_drn, write_drn
from posgmc.model.explicit import ExplicitModel, Observation, RewardModel, make_model
from posgmc.syntax.ast import ModelType
from tests.io.helpers import (
    BENCHMARK_SIZES,
    assert_same_model,
    tiny_dtmc,
    tiny_mdp,
    tiny_pomdp,
    tiny_posg,
    tiny_smg,
)

ROOT = Path(__file__).resolve().parents[2]

TINY = [tiny_dtmc, tiny_mdp, tiny_pomdp, tiny_smg, tiny_posg]


@pytest.mark.parametrize("build", TINY, ids=lambda f: f.__name__)
def test_round_trip_tiny(build: object, tmp_path: Path) -> None:
    model = build()  # type: ignore[operator]
    path = tmp_path / "m.drn"
    write_drn(model, path, valuations=True)
    again = read_drn(path)
    assert_same_model(model, again)
    # Writing the model read back gives the same text: the format is a fixed point.
    assert drn_text(again, valuations=True) == path.read_text()


@pytest.mark.parametrize(
    "relative", [row[0] for row in BENCHMARK_SIZES], ids=lambda r: r.split("/")[1]
)
def test_round_trip_benchmarks(benchmarks: Path, relative: str) -> None:
    model = read_drn(benchmarks / relative)
    assert_same_model(model, parse_drn(drn_text(model)))


def test_mdp_text_line_by_line() -> None:
    """The exact text for tiny_mdp (helpers.py): Storm's layout, rewards without blanks."""
    assert drn_text(tiny_mdp(), valuations=True, header_comment="line one\nline two") == (
        "// Exported by posgmc\n"
        "// Original model type: mdp\n"
        "// line one\n"
        "// line two\n"
        "@type: MDP\n"
        "@parameters\n"
        "\n"
        "@reward_models\n"
        "r t \n"
        "@nr_states\n"
        "3\n"
        "@nr_choices\n"
        "4\n"
        "@model\n"
        'state 0 [0,0] init "two words"\n'
        "//[x=0\t& b=0]\n"
        "\taction a [2.5,0]\n"
        "\t\t1 : 0.3\n"
        "\t\t2 : 0.7\n"
        "\taction b [0,0.1]\n"
        "\t\t0 : 1\n"
        "state 1 [1,0] goal\n"
        "//[x=1\t& b=1]\n"
        "\taction __NOLABEL__ [0,0]\n"
        "\t\t1 : 1\n"
        'state 2 [0,0] deadlock "two words"\n'
        "//[x=-2\t& b=0]\n"
        "\taction __NOLABEL__ [0,0]\n"
        "\t\t2 : 1\n"
    )


def test_without_valuations_they_are_not_written() -> None:
    text = drn_text(tiny_mdp())
    assert "//[" not in text
    assert parse_drn(text).variable_names == ()


def test_games_write_players_and_observations() -> None:
    text = drn_text(tiny_posg())
    assert "//@players: p1 p2\n@type: POSMG\n" in text
    assert "state 1 {1} <1>\n" in text
    assert "@type: SMG" in drn_text(tiny_smg())
    assert "{" not in drn_text(tiny_smg()).split("@model")[1]


def test_posg_without_observations_is_written_as_smg() -> None:
    smg = tiny_smg()
    posg = make_model(
        ModelType.POSG,
        smg.row_groups,
        smg.transitions,
        choice_actions=smg.choice_actions,
        action_names=smg.action_names,
        state_players=smg.state_players,
        player_names=smg.player_names,
    )
    assert parse_drn(drn_text(posg)).model_type is ModelType.SMG


def test_posg_with_different_observations_needs_an_observer() -> None:
    model = tiny_posg(same_observations=False)
    with pytest.raises(UnsupportedError) as info:
        drn_text(model)
    assert "observe the game differently" in info.value.message
    assert info.value.hint is not None and "observer=" in info.value.hint
    for observer, ids in (("p1", [0, 1, 1]), (1, [0, 1, 2])):
        again = parse_drn(drn_text(model, observer=observer))
        assert again.observations[0].state_ids.tolist() == ids
    with pytest.raises(UnsupportedError):
        drn_text(model, observer="nobody")


def test_write_to_stream() -> None:
    stream = io.StringIO()
    write_drn(tiny_dtmc(), stream)
    assert stream.getvalue() == drn_text(tiny_dtmc())


def _mdp_with(**overrides: object) -> ExplicitModel:
    base = dict(
        choice_actions=[0, 0],
        action_names=("",),
        labels={"goal": [False, True]},
        reward_models=(),
    )
    base.update(overrides)
    return make_model(ModelType.MDP, [0, 1, 2], [[0, 1], [0, 1]], **base)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("model", "fragment"),
    [
        (_mdp_with(reward_models=(RewardModel("r", state=np.array([np.inf, 0])),)), "reward inf"),
        (
            _mdp_with(reward_models=(RewardModel("my r", state=np.array([1.0, 0])),)),
            'name "my r" contains a space',
        ),
        (_mdp_with(labels={'say "hi"': [True, False]}), "cannot be written in DRN"),
        (
            _mdp_with(action_names=("", "a b"), choice_actions=[1, 0]),
            'action name "a b" contains a space',
        ),
    ],
    ids=["infinite-reward", "reward-name-space", "label-quote", "action-space"],
)
def test_unwritable_models(model: ExplicitModel, fragment: str, tmp_path: Path) -> None:
    path = tmp_path / "m.drn"
    path.write_text("old content\n")
    with pytest.raises(UnsupportedError) as info:
        write_drn(model, path)
    assert fragment in info.value.message
    # Atomic: the old file is untouched and no temporary file is left behind.
    assert path.read_text() == "old content\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.drn"]


def test_write_error_leaves_no_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """An I/O error in the middle of writing leaves neither the target nor a temporary file."""
    import posgmc.io.atomic as atomic

    real_replace = atomic.os.replace

    def failing_replace(src: str, dst: str) -> None:
        raise OSError("disk full")

    monkeypatch.setattr(atomic.os, "replace", failing_replace)
    # the error names the user's path, never the temporary file (issue #13)
    with pytest.raises(InputError, match=f"cannot write {tmp_path / 'm.drn'}: disk full"):
        write_drn(tiny_mdp(), tmp_path / "m.drn")
    monkeypatch.setattr(atomic.os, "replace", real_replace)
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------------------------------
# Exact numbers
# ---------------------------------------------------------------------------------------------


@given(st.lists(st.floats(allow_nan=False, allow_infinity=False), min_size=1, max_size=50))
def test_format_values_round_trips_exactly(values: list[float]) -> None:
    texts = format_values(np.array(values)).tolist()
    assert [float(t) for t in texts] == [float(v) for v in values]


def test_format_values_writes_integers_plainly() -> None:
    assert format_values(np.array([1.0, -3.0, 0.5, 1e-5, 2.0**60])).tolist() == [
        "1",
        "-3",
        "0.5",
        "1e-05",
        "1.152921504606847e+18",
    ]


# ---------------------------------------------------------------------------------------------
# Random models
# ---------------------------------------------------------------------------------------------


@st.composite
def random_models(draw: st.DrawFn) -> ExplicitModel:
    model_type = draw(st.sampled_from(list(ModelType)))
    num_states = draw(st.integers(1, 6))
    nondet = model_type is not ModelType.DTMC
    per_state = [draw(st.integers(1, 3)) if nondet else 1 for _ in range(num_states)]
    row_groups = np.concatenate(([0], np.cumsum(per_state)))
    num_choices = int(row_groups[-1])
    matrix = np.zeros((num_choices, num_states))
    for c in range(num_choices):
        targets = draw(
            st.lists(st.integers(0, num_states - 1), min_size=1, max_size=3, unique=True)
        )
        weights = [draw(st.integers(1, 7)) for _ in targets]
        matrix[c, targets] = np.array(weights) / sum(weights)
    action_pool = ("", "a", "b", "go_1")
    actions = [draw(st.integers(0, len(action_pool) - 1)) for _ in range(num_choices)]
    used = sorted(set(actions) | {0})
    names = tuple(action_pool[i] for i in used)
    choice_actions = [used.index(a) for a in actions]
    game = model_type.is_game
    players = [draw(st.integers(0, 1)) for _ in range(num_states)] if game else None
    player_names = ("p1", "p2") if game else ()
    observations: tuple[Observation, ...] = ()
    if model_type.is_partially_observable:
        # states sharing an observation offer the same actions (the rule every input obeys)
        drawn = [draw(st.integers(0, 2)) for _ in range(num_states)]
        offered = [
            (frozenset(choice_actions[row_groups[i] : row_groups[i + 1]]), per_state[i])
            for i in range(num_states)
        ]
        keys: dict[object, int] = {}
        ids = np.array(
            [keys.setdefault((z, sig), len(keys)) for z, sig in zip(drawn, offered)], dtype=np.int32
        )
        values = np.zeros((int(ids.max()) + 1, 0), dtype=np.int64)
        observers = (0, 1) if game else (0,)
        observations = tuple(Observation(p, ids, (), values) for p in observers)
    label_values = [draw(st.booleans()) for _ in range(num_states)]
    finite = st.floats(-1e6, 1e6, allow_nan=False, allow_subnormal=False)
    rewards = tuple(
        RewardModel(
            name,
            np.array([draw(finite) for _ in range(num_states)]) if draw(st.booleans()) else None,
            np.array([draw(finite) for _ in range(num_choices)]) if draw(st.booleans()) else None,
        )
        for name in draw(st.sampled_from([(), ("r",), ("r", None), ("a", "b")]))
    )
    num_vars = draw(st.integers(0, 2))
    state_values = [[draw(st.integers(-5, 5)) for _ in range(num_vars)] for _ in range(num_states)]
    initial = sorted(set(draw(st.lists(st.integers(0, num_states - 1), min_size=1, max_size=2))))
    return make_model(
        model_type,
        row_groups,
        matrix,
        initial_states=initial,
        choice_actions=choice_actions,
        action_names=names,
        state_players=players,
        player_names=player_names,
        observations=observations,
        labels={"goal": label_values, "a b": label_values[::-1]},
        reward_models=rewards,
        variable_names=("x", "y")[:num_vars],
        state_values=np.array(state_values, dtype=np.int64).reshape(num_states, num_vars),
    )


@settings(max_examples=60, deadline=None)
@given(random_models())
def test_round_trip_random_models(model: ExplicitModel) -> None:
    again = parse_drn(drn_text(model, valuations=True))
    # All-zero reward models survive too: every state and action line carries one value each.
    assert_same_model(model, again)


def test_written_files_get_ordinary_permissions(tmp_path: Path) -> None:
    """A new file gets 0666 minus the umask (not mkstemp's 0600); a replaced one keeps its mode."""
    import os

    umask = os.umask(0)
    os.umask(umask)
    path = tmp_path / "m.drn"
    write_drn(tiny_mdp(), path)
    assert path.stat().st_mode & 0o777 == 0o666 & ~umask
    path.chmod(0o640)
    write_drn(tiny_mdp(), path)
    assert path.stat().st_mode & 0o777 == 0o640


@pytest.mark.parametrize("chunk", [1, 2, 3, 7, 1000])
def test_chunked_text_equals_the_whole(chunk: int) -> None:
    # issue #13: the writer streams chunks of states; any chunking gives the same text
    from posgmc.io.drn.writer import iter_drn

    for path in ("models/rover.smg", "models/rover.posg"):
        model = api.build(api.load(ROOT / path)).model
        whole = "".join(iter_drn(model, valuations=True, chunk_entries=10**9))
        pieces = list(iter_drn(model, valuations=True, chunk_entries=chunk))
        assert "".join(pieces) == whole
        if chunk < 10:
            assert len(pieces) > 2
