"""Reading Storm's DRN format: the benchmark files, every feature of the format, every error."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.errors import ModelFormatError, PosgmcError, UnsupportedError
from posgmc.io.drn import parse_drn, read_drn
from posgmc.syntax.ast import ModelType
from tests.io.helpers import BENCHMARK_SIZES

# ---------------------------------------------------------------------------------------------
# The benchmark DRN files
# ---------------------------------------------------------------------------------------------



def test_every_drn_benchmark_is_listed(benchmarks: Path) -> None:
    """Every file under benchmarks/ with a DRN header is in BENCHMARK_SIZES."""
    found = set()
    for path in benchmarks.rglob("*"):
        if path.is_file() and path.suffix not in (".md",):
            head = path.read_bytes()[:400]
            if b"\n@type:" in head or head.startswith(b"@type:"):
                found.add(path.relative_to(benchmarks).as_posix())
    assert found == {row[0] for row in BENCHMARK_SIZES}


@pytest.mark.parametrize(
    ("relative", "model_type", "states", "choices", "transitions"),
    BENCHMARK_SIZES,
    ids=[row[0].split("/")[1] for row in BENCHMARK_SIZES],
)
def test_benchmark_sizes_match_storm(
    benchmarks: Path,
    relative: str,
    model_type: ModelType,
    states: int,
    choices: int,
    transitions: int,
) -> None:
    model = read_drn(benchmarks / relative)
    assert model.model_type is model_type
    assert (model.num_states, model.num_choices, model.num_transitions) == (
        states,
        choices,
        transitions,
    )
    # No benchmark has a repeated target within a choice, so Storm's entry count (one per
    # transition line) equals ours (distinct targets per choice).
    lines = (benchmarks / relative).read_text().split("\n")
    assert sum(1 for line in lines if ":" in line and line.strip()[:1].isdigit()) == transitions
    assert model.label("init").sum() == 1


def test_pomdp_observation_counts(benchmarks: Path) -> None:
    # RESULTS.md section 2: 4x3-95 has 9 observations, query-s2 has 6.
    assert read_drn(benchmarks / "pomdp/4x3-95/sketch.templ").observations[0].num_observations == 9
    assert (
        read_drn(benchmarks / "pomdp/query-s2/sketch.templ").observations[0].num_observations == 6
    )


def test_test_game_details(benchmarks: Path) -> None:
    """posmg/test-game, read off the file: 'state 0 {0} <1> init', actions odd/even, then
    dbl/add."""
    model = read_drn(benchmarks / "posmg/test-game/sketch.templ")
    assert model.player_names == ("0", "1")
    assert model.state_players.tolist() == [1, 0, 0, 0, 0, 0, 1, 1]
    assert [o.player for o in model.observations] == [0, 1]
    assert model.observations[0].state_ids.tolist() == [0, 1, 2, 1, 2, 1, 3, 3]
    np.testing.assert_array_equal(model.observations[1].state_ids, model.observations[0].state_ids)
    assert model.observations[0].num_observations == 4
    assert model.initial_states.tolist() == [0]
    names = [model.action_names[a] for a in model.choice_actions]
    assert names[:4] == ["odd", "even", "dbl", "add"]
    assert model.action_names[0] == ""
    # state 1, action add: 2 : 0.75, 7 : 0.25
    row = model.transitions.getrow(int(model.row_groups[1]) + 1)
    assert dict(zip(row.indices.tolist(), row.data.tolist())) == {2: 0.75, 7: 0.25}
    assert model.reward_models == ()


def test_testing_rewards_has_two_unnamed_reward_models(benchmarks: Path) -> None:
    """'@reward_models' is followed by ' ' (two empty names); 'state 2 {4} <0> [0, 101] ...',
    'action roll2 [2, 0]' (states 4-7), per the file."""
    model = read_drn(benchmarks / "posmg/testing-rewards/sketch.templ")
    assert [rm.name for rm in model.reward_models] == [None, None]
    first, second = model.reward_models
    assert first.state is None  # every state's first value is 0
    assert second.state is not None and second.state[2] == 101 and second.state[0] == 1
    assert first.choice is not None
    assert first.choice[model.row_groups[4]] == 2
    assert second.choice is None
    assert model.label("deadlock")[[1, 2]].all()
    np.testing.assert_array_equal(model.deadlocks, np.flatnonzero(model.label("deadlock")))


def test_4x3_rewards_and_actions(benchmarks: Path) -> None:
    """'@reward_models' / 'reward ' names one model; 'action (n) [-0.04]' etc. per the file."""
    model = read_drn(benchmarks / "pomdp/4x3-95/sketch.templ")
    (reward,) = model.reward_models
    assert reward.name == "reward"
    assert reward.state is None
    assert reward.choice is not None and reward.choice[1] == -0.04
    assert model.action_names[:3] == ("", "(init)", "(n)")
    assert model.player_names == ()
    assert model.state_players.tolist() == [0] * 22


def test_crlf_file_reads_like_lf(benchmarks: Path) -> None:
    path = benchmarks / "posmg/dodge-6-lines/sketch.templ"
    assert b"\r\n" in path.read_bytes()[:100]  # this benchmark has Windows line endings
    crlf = read_drn(path)
    lf = parse_drn(path.read_text().replace("\r\n", "\n"))
    assert (crlf.transitions != lf.transitions).nnz == 0
    assert crlf.num_states == lf.num_states


# ---------------------------------------------------------------------------------------------
# Features of the format on small texts
# ---------------------------------------------------------------------------------------------

MDP = """\
// test
@type: MDP
@parameters

@reward_models
r
@nr_states
2
@nr_choices
3
@model
state 0 [1] init
\taction a [2]
\t\t0 : 0.5
\t\t1 : 1/2
\taction b [0]
\t\t1 : 1
state 1 [0] goal
\taction __NOLABEL__ [0]
\t\t1 : 1
"""


def variant(
    text: str = MDP,
    *,
    replace: dict[int, str] | None = None,
    delete: tuple[int, ...] = (),
    insert: dict[int, str] | None = None,
) -> str:
    """``text`` with 1-based lines replaced, deleted, or inserted before."""
    lines = text.split("\n")
    out = []
    for number, line in enumerate(lines, start=1):
        if insert and number in insert:
            out.append(insert[number])
        if number in delete:
            continue
        out.append((replace or {}).get(number, line))
    return "\n".join(out)


def test_small_mdp() -> None:
    model = parse_drn(MDP, file="m.drn")
    assert model.model_type is ModelType.MDP
    assert model.row_groups.tolist() == [0, 2, 3]
    assert model.transitions.toarray().tolist() == [[0.5, 0.5], [0, 1], [0, 1]]
    assert [model.action_names[a] for a in model.choice_actions] == ["a", "b", ""]
    (r,) = model.reward_models
    assert r.name == "r"
    assert r.state is not None and r.state.tolist() == [1, 0]
    assert r.choice is not None and r.choice.tolist() == [2, 0, 0]
    assert model.label("goal").tolist() == [False, True]
    assert model.label("deadlock").tolist() == [False, False]
    assert model.variable_names == () and model.state_values.shape == (2, 0)


def test_comments_blank_lines_and_crlf_anywhere() -> None:
    text = variant(insert={12: "// a comment", 14: "", 18: "   // indented comment"})
    text = text.replace("\n", "\r\n")
    model = parse_drn(text)
    assert model.transitions.toarray().tolist() == [[0.5, 0.5], [0, 1], [0, 1]]


def test_quoted_labels() -> None:
    model = parse_drn(variant(replace={18: 'state 1 [0] "two words" goal "[x]"'}))
    assert model.label("two words").tolist() == [False, True]
    assert model.label("[x]").tolist() == [False, True]
    assert model.label("goal").tolist() == [False, True]


def test_fractions_placeholders_and_value_type() -> None:
    text = variant(
        replace={
            2: "@type: MDP\n@value_type: rational\n@placeholders\n$h : 1/4\n$q : 3/4",
            14: "\t\t0 : $h",
            15: "\t\t1 : $q",
        }
    )
    model = parse_drn(text)
    assert model.transitions.toarray()[0].tolist() == [0.25, 0.75]


def test_repeated_targets_are_summed_and_zeros_dropped() -> None:
    # Storm 2.0 does the same: stormpy.build_model_from_drn on a choice "1 : 0.25, 1 : 0.25,
    # 0 : 0.5" gave nr_transitions 2 for it (checked by hand with the reference stormpy).
    model = parse_drn(variant(replace={14: "\t\t0 : 0.25\n\t\t0 : 0.25\n\t\t1 : 0"}, delete=()))
    assert model.transitions.toarray()[0].tolist() == [0.5, 0.5]
    assert model.num_transitions == 4


def test_index_actions_mean_unlabelled() -> None:
    # Storm writes "action 0", "action 1", ... when the model has no choice labels.
    text = variant(replace={13: "\taction 0 [2]", 16: "\taction 1 [0]", 19: "\taction 0 [0]"})
    model = parse_drn(text)
    assert model.action_names == ("",)
    assert model.choice_actions.tolist() == [0, 0, 0]


def test_reward_model_names_follow_storm() -> None:
    # Names are split at single blanks; missing names are "rew<i>"; empty names are unnamed.
    three = {
        12: "state 0 [1, 2, 3] init",
        13: "\taction a []",
        16: "\taction b []",
        18: "state 1 [0,0,0] goal",
        19: "\taction __NOLABEL__",
    }
    model = parse_drn(variant(replace={6: "", **three}))
    assert [rm.name for rm in model.reward_models] == [None, "rew1", "rew2"]
    assert [rm.state.tolist() for rm in model.reward_models if rm.state is not None] == [
        [1, 0],
        [2, 0],
        [3, 0],
    ]
    assert all(rm.choice is None for rm in model.reward_models)
    named = parse_drn(variant(replace={6: "a b "}))
    assert [rm.name for rm in named.reward_models] == ["a"]


def test_empty_reward_brackets_are_zero() -> None:
    empty = {
        6: "",
        12: "state 0 [] init",
        13: "\taction a []",
        16: "\taction b []",
        18: "state 1 [] goal",
        19: "\taction __NOLABEL__ []",
    }
    assert parse_drn(variant(replace=empty)).reward_models == ()


def test_no_nr_choices_is_accepted() -> None:
    # Storm only warns when @nr_choices is missing.
    model = parse_drn(variant(delete=(9, 10)))
    assert model.num_choices == 3


def test_dtmc_with_and_without_action_lines() -> None:
    text = """\
@type: DTMC
@parameters

@reward_models

@nr_states
2
@model
state 0 init
\t\t1 : 1
state 1
\taction __NOLABEL__
\t\t0 : 0.5
\t\t1 : 0.5
"""
    model = parse_drn(text)
    assert model.model_type is ModelType.DTMC
    assert model.row_groups.tolist() == [0, 1, 2]
    assert model.transitions.toarray().tolist() == [[0, 1], [0.5, 0.5]]


def test_valuations() -> None:
    text = variant(insert={13: "//[x=0\t& b\t& !c]", 19: "//[x=-3\t& !b\t& c]"})
    model = parse_drn(text)
    assert model.variable_names == ("x", "b", "c")
    assert model.state_values.tolist() == [[0, 1, 0], [-3, 0, 1]]


def test_valuations_with_storm_true_bool_bug_are_dropped() -> None:
    # Storm 2.0 writes a true Boolean b as an empty item: "//[\t& x=0]" (seen in its output).
    text = variant(insert={13: "//[!b\t& x=0]", 19: "//[\t& x=1]"})
    model = parse_drn(text)
    assert model.variable_names == ()
    assert model.state_values.shape == (2, 0)


def test_valuations_missing_for_some_state_are_dropped() -> None:
    model = parse_drn(variant(insert={13: "//[x=0]"}))
    assert model.variable_names == ()


POSMG = """\
// Exported by prism
//@players: alice bob
@type: POSMG
@parameters

@reward_models

@nr_states
2
@nr_choices
3
@model
state 0 {0} <1> init
\taction a []
\t\t1 : 1
\taction b []
\t\t0 : 1
state 1 {0} <0> goal
\taction __NOLABEL__ []
\t\t1 : 1
"""


def test_posmg_with_player_names() -> None:
    model = parse_drn(POSMG)
    assert model.model_type is ModelType.POSG
    assert model.player_names == ("alice", "bob")
    assert model.state_players.tolist() == [1, 0]
    assert [o.player for o in model.observations] == [0, 1]
    assert model.observations[0].num_observations == 1
    assert model.statistics()["players"] == {"alice": 1, "bob": 1}


def test_smg() -> None:
    model = parse_drn(
        variant(
            POSMG, replace={2: "", 3: "@type: SMG", 13: "state 0 <1> init", 18: "state 1 <2> goal"}
        )
    )
    assert model.model_type is ModelType.SMG
    assert model.player_names == ("0", "1", "2")
    assert model.observations == ()


def test_read_from_path_and_text(tmp_path: Path) -> None:
    path = tmp_path / "m.drn"
    path.write_text(MDP)
    assert read_drn(path).num_states == 2
    assert read_drn(str(path)).num_states == 2
    assert read_drn(MDP).num_states == 2
    bad = tmp_path / "bad.drn"
    bad.write_text(variant(replace={18: "state 2 [0] goal"}))
    with pytest.raises(ModelFormatError) as info:
        read_drn(bad)
    assert info.value.span is not None and info.value.span.file == str(bad)
    with pytest.raises(ModelFormatError) as info:
        read_drn(bad, file="shown.drn")
    assert str(info.value).startswith("shown.drn:18:7: ")


# ---------------------------------------------------------------------------------------------
# Malformed input: every error has a message, a line and a column
# ---------------------------------------------------------------------------------------------

GAME_HEADER = {1: "", 2: "@type: POSMG"}

ERRORS = [
    # (id, text, error class, message fragment, line, column)
    (
        "unknown-type",
        variant(replace={2: "@type: FOO"}),
        ModelFormatError,
        'unknown model type "FOO"',
        2,
        1,
    ),
    (
        "ctmc",
        variant(replace={2: "@type: CTMC"}),
        UnsupportedError,
        "continuous-time Markov chains",
        2,
        8,
    ),
    (
        "parametric",
        variant(replace={4: "p q"}),
        UnsupportedError,
        "parametric models are not supported",
        4,
        1,
    ),
    (
        "interval",
        variant(insert={3: "@value_type: double-interval"}),
        UnsupportedError,
        "double-interval values",
        3,
        1,
    ),
    (
        "nr-states-text",
        variant(replace={8: "two"}),
        ModelFormatError,
        "expected a non-negative integer on the line after @nr_states",
        8,
        1,
    ),
    (
        "no-nr-states",
        variant(delete=(7, 8)),
        ModelFormatError,
        "number of states must be declared before @model",
        9,
        1,
    ),
    (
        "no-type",
        variant(delete=(2,)),
        ModelFormatError,
        "model type must be declared before @model",
        10,
        1,
    ),
    (
        "header-garbage",
        variant(insert={3: "@states"}),
        ModelFormatError,
        "unexpected line in the DRN header",
        3,
        1,
    ),
    (
        "declared-twice",
        variant(insert={7: "@type: MDP"}),
        ModelFormatError,
        "@type is declared twice (first on line 2)",
        7,
        1,
    ),
    (
        "no-model",
        "@type: MDP\n@nr_states\n1\n",
        ModelFormatError,
        "the file ends before @model",
        3,
        1,
    ),
    (
        "no-states",
        variant(delete=tuple(range(12, 21))),
        ModelFormatError,
        "the model has no states",
        11,
        1,
    ),
    (
        "action-first",
        variant(insert={12: "\taction a"}),
        ModelFormatError,
        "expected a line 'state 0 ...' first",
        12,
        2,
    ),
    (
        "state-order",
        variant(replace={18: "state 2 [0] goal"}),
        ModelFormatError,
        "expected state 1, found state 2",
        18,
        7,
    ),
    (
        "state-id-text",
        variant(replace={18: "state one [0] goal"}),
        ModelFormatError,
        'state number must be a non-negative integer, found "one"',
        18,
        7,
    ),
    (
        "too-many-states",
        variant(replace={8: "1"}),
        ModelFormatError,
        "more states than @nr_states declares (1)",
        18,
        1,
    ),
    (
        "too-few-states",
        variant(replace={8: "3"}),
        ModelFormatError,
        "@nr_states declares 3 states, but the model has 2",
        8,
        1,
    ),
    (
        "too-many-choices",
        variant(replace={10: "2"}),
        ModelFormatError,
        "more choices than @nr_choices declares (2)",
        19,
        2,
    ),
    (
        "too-few-choices",
        variant(replace={10: "4"}),
        ModelFormatError,
        "@nr_choices declares 4 choices, but the model has 3",
        10,
        1,
    ),
    (
        "no-colon",
        variant(replace={17: "\t\t1 1"}),
        ModelFormatError,
        "expected a transition '<target> : <probability>'",
        17,
        3,
    ),
    (
        "target-text",
        variant(replace={17: "\t\tx : 1"}),
        ModelFormatError,
        'target state must be a state number, found "x"',
        17,
        3,
    ),
    (
        "target-range",
        variant(replace={17: "\t\t5 : 1"}),
        ModelFormatError,
        "target state 5 does not exist (the model has states 0 to 1)",
        17,
        3,
    ),
    (
        "prob-text",
        variant(replace={17: "\t\t1 : abc"}),
        ModelFormatError,
        'the probability "abc" is not a number',
        17,
        7,
    ),
    (
        "prob-underscore",
        variant(replace={17: "\t\t1 : 1_0"}),
        ModelFormatError,
        'the probability "1_0" is not a number',
        17,
        7,
    ),
    (
        "prob-inf",
        variant(replace={17: "\t\t1 : inf"}),
        ModelFormatError,
        'the probability "inf" is not a finite number',
        17,
        7,
    ),
    (
        "prob-div-zero",
        variant(replace={17: "\t\t1 : 1/0"}),
        ModelFormatError,
        'the probability "1/0" is not a number',
        17,
        7,
    ),
    (
        "prob-negative",
        variant(replace={14: "\t\t0 : -0.5", 15: "\t\t1 : 1.5"}),
        ModelFormatError,
        'the probability "-0.5" is negative',
        14,
        7,
    ),
    (
        "prob-above-one",
        variant(replace={14: "\t\t0 : 0", 15: "\t\t1 : 1.5"}),
        ModelFormatError,
        'the probability "1.5" is greater than 1',
        15,
        7,
    ),
    (
        "placeholder-undefined",
        variant(replace={17: "\t\t1 : $p"}),
        ModelFormatError,
        'the probability "$p" is not a defined placeholder',
        17,
        7,
    ),
    (
        "placeholder-malformed",
        variant(insert={3: "@placeholders\np = 1"}),
        ModelFormatError,
        "expected a placeholder definition '$name : value'",
        4,
        1,
    ),
    (
        "sum",
        variant(replace={15: "\t\t1 : 0.4"}),
        ModelFormatError,
        "the probabilities of this choice sum to 0.9, not 1",
        13,
        2,
    ),
    ("no-actions", variant(delete=(19, 20)), ModelFormatError, "state 1 has no actions", 18, 1),
    (
        "no-transitions",
        variant(delete=(17,)),
        ModelFormatError,
        "this choice has no transitions",
        16,
        2,
    ),
    (
        "orphan-transition",
        variant(insert={13: "\t\t0 : 1"}),
        ModelFormatError,
        "a transition must follow an 'action' line",
        13,
        3,
    ),
    (
        "reward-count",
        variant(replace={13: "\taction a [2, 3]"}),
        ModelFormatError,
        "expected 2 reward values (one per reward model), found 1",
        12,
        9,
    ),
    (
        "reward-text",
        variant(replace={12: "state 0 [x] init"}),
        ModelFormatError,
        'the reward "x" is not a number',
        12,
        10,
    ),
    (
        "reward-empty",
        variant(replace={12: "state 0 [1,] init"}),
        ModelFormatError,
        "empty reward value",
        12,
        12,
    ),
    (
        "bracket-open",
        variant(replace={12: "state 0 [1 init"}),
        ModelFormatError,
        "missing ']' to close the reward list",
        12,
        9,
    ),
    (
        "bracket-glued",
        variant(replace={12: "state 0 [1]init"}),
        ModelFormatError,
        "expected a space after the reward list",
        12,
        12,
    ),
    (
        "obs-in-mdp",
        variant(replace={12: "state 0 {1} [1] init"}),
        ModelFormatError,
        "observations '{z}' are only allowed in POMDP and POSMG files",
        12,
        9,
    ),
    (
        "player-in-mdp",
        variant(replace={12: "state 0 <1> [1] init"}),
        ModelFormatError,
        "players '<p>' are only allowed in SMG and POSMG files",
        12,
        9,
    ),
    (
        "no-init",
        variant(replace={12: "state 0 [1]"}),
        ModelFormatError,
        "no state is labelled init",
        12,
        1,
    ),
    (
        "label-quote-open",
        variant(replace={18: 'state 1 [0] "goal'}),
        ModelFormatError,
        "missing '\"' to close the label",
        18,
        13,
    ),
    (
        "label-quote-inside",
        variant(replace={18: 'state 1 [0] go"al"'}),
        ModelFormatError,
        "a label with quotes must be quoted as a whole",
        18,
        13,
    ),
    (
        "label-empty",
        variant(replace={18: 'state 1 [0] ""'}),
        ModelFormatError,
        "empty label",
        18,
        13,
    ),
    (
        "action-no-name",
        variant(replace={13: "\taction [2]"}),
        ModelFormatError,
        "expected an action name (or __NOLABEL__) after 'action'",
        13,
        9,
    ),
    (
        "action-two-words",
        variant(replace={13: "\taction a b [2]"}),
        ModelFormatError,
        "unexpected text after the action name",
        13,
        11,
    ),
    (
        "action-after-rewards",
        variant(replace={13: "\taction a [2] x"}),
        ModelFormatError,
        "unexpected text after the action's rewards",
        13,
        15,
    ),
    (
        "pomdp-no-obs",
        variant(replace={2: "@type: POMDP", 12: "state 0 [1] init"}),
        ModelFormatError,
        "expected the observation '{z}' of state 0",
        12,
        9,
    ),
    (
        "pomdp-obs-text",
        variant(replace={2: "@type: POMDP", 12: "state 0 {a} [1] init"}),
        ModelFormatError,
        'the observation must be a non-negative integer, found "a"',
        12,
        10,
    ),
    (
        "pomdp-obs-open",
        variant(replace={2: "@type: POMDP", 12: "state 0 {1 [1] init"}),
        ModelFormatError,
        "missing '}' to close the observation",
        12,
        9,
    ),
    (
        "posmg-no-player",
        variant(POSMG, replace={13: "state 0 {0} init"}),
        ModelFormatError,
        "expected the player '<p>' who owns state 0",
        13,
        13,
    ),
    (
        "posmg-order",
        variant(POSMG, replace={13: "state 0 <1> {0} init"}),
        ModelFormatError,
        "expected the observation '{z}' of state 0",
        13,
        9,
    ),
    (
        "posmg-player-name",
        variant(POSMG, replace={13: "state 0 {0} <bob> init"}),
        ModelFormatError,
        'the player must be a non-negative integer, found "bob"',
        13,
        14,
    ),
    (
        "players-comment",
        variant(POSMG, replace={2: "//@players: alice"}),
        ModelFormatError,
        "must name 2 distinct players",
        2,
        1,
    ),
    (
        "dtmc-two-actions",
        variant(replace={2: "@type: DTMC", 10: "2"}),
        ModelFormatError,
        "a state of a DTMC has exactly one action",
        16,
        2,
    ),
]


@pytest.mark.parametrize(
    ("text", "error", "fragment", "line", "column"),
    [case[1:] for case in ERRORS],
    ids=[case[0] for case in ERRORS],
)
def test_malformed_input(
    text: str, error: type[PosgmcError], fragment: str, line: int, column: int
) -> None:
    with pytest.raises(PosgmcError) as info:
        parse_drn(text, file="bad.drn")
    e = info.value
    assert type(e) is error
    assert fragment in e.message
    assert e.span is not None
    assert (e.span.file, e.span.line, e.span.column) == ("bad.drn", line, column)
    rendered = e.render()
    assert rendered.startswith(f"bad.drn:{line}:{column}: error: ")
    # The offending line is shown with a caret under the column.
    shown = text.split("\n")[line - 1].rstrip("\r")
    assert "  " + shown.expandtabs(4) in rendered
    caret_line = rendered.split("\n")[2]
    assert caret_line.index("^") == 2 + len(shown[: column - 1].expandtabs(4))


def test_error_hint_for_state_order() -> None:
    with pytest.raises(ModelFormatError) as info:
        parse_drn(variant(replace={18: "state 2 [0] goal"}))
    assert info.value.hint == "state numbers must be 0, 1, 2, ... in order and without gaps"


# ---------------------------------------------------------------------------------------------
# Robustness: any edit of a valid file parses or fails with a positioned input error
# ---------------------------------------------------------------------------------------------

_ALPHABET = st.sampled_from(list(' \t\n0123456789.,:/[]{}<>"$!&=-abinot_@'))


@st.composite
def _edited(draw: st.DrawFn) -> str:
    text = draw(
        st.sampled_from([MDP, POSMG, variant(insert={13: "//[x=0\t& b]", 19: "//[x=1\t& !b]"})])
    )
    for _ in range(draw(st.integers(1, 4))):
        at = draw(st.integers(0, len(text)))
        kind = draw(st.sampled_from(["insert", "delete", "replace"]))
        char = draw(_ALPHABET)
        if kind == "insert":
            text = text[:at] + char + text[at:]
        elif kind == "delete":
            text = text[:at] + text[at + 1 :]
        else:
            text = text[:at] + char + text[at + 1 :]
    return text


@settings(max_examples=400, deadline=None)
@given(_edited())
def test_edits_parse_or_fail_with_position(text: str) -> None:
    try:
        model = parse_drn(text, file="f.drn")
    except (ModelFormatError, UnsupportedError) as e:
        assert e.span is not None and e.span.file == "f.drn"
        assert 1 <= e.span.line <= text.count("\n") + 1
        assert e.span.column >= 1
        e.render()
    else:
        model.validate()


_CONFLICT = """@type: POMDP
@parameters

@reward_models

@nr_states
3
@nr_choices
4
@model
state 0 {0} init
\taction A0
\t\t1 : 1
\taction B0
\t\t2 : 1
state 1 {1}
\taction A1
\t\t1 : 1
state 2 {1}
\taction B1
\t\t2 : 1
"""


def _conflict(**actions: str) -> str:
    text = _CONFLICT
    for key, name in actions.items():
        text = text.replace(key.upper(), name)
    return text


def test_same_observation_different_actions_is_refused_as_in_prism() -> None:
    # issue #13: accepted from DRN while the same POMDP written in PRISM was an error
    from posgmc.errors import ModelFormatError

    text = _conflict(a0="a", b0="b", a1="a", b1="b")
    with pytest.raises(ModelFormatError) as info:
        parse_drn(text)
    assert info.value.span is not None and info.value.span.line == 19  # "state 2 {1}"
    assert info.value.message == (
        "states 1 and 2 look the same to the agent (observation 1) but offer different actions: "
        "[a] only in the first, [b] only in the second"
    )
    # with no action labels (Storm's numbering), the number of choices must agree
    unlabelled = _conflict(a0="0", b0="1", a1="0", b1="0").replace("state 2 {1}", "state 2 {0}")
    with pytest.raises(ModelFormatError, match="states 0 and 2 .* 2 choices"):
        parse_drn(unlabelled)
    assert parse_drn(_conflict(a0="a", b0="b", a1="a", b1="a")).num_states == 3


def test_a_nul_character_is_a_positioned_error() -> None:
    # found by the long fuzz run (issue #13): numpy's strings dropped it and int() failed later
    from posgmc.errors import ModelFormatError

    text = _conflict(a0="a", b0="b", a1="a", b1="a").replace("state 1 {1}", "state 1\x00 {1}")
    with pytest.raises(ModelFormatError, match="NUL character") as info:
        parse_drn(text)
    assert info.value.span is not None and (info.value.span.line, info.value.span.column) == (16, 8)
