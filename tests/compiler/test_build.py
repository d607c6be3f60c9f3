"""The builder's semantics on small models written out in the PRISM language.

Every expected number is derived by hand in a comment next to it (or follows from the rule the test
names); every error is checked for its message and its position in the model text.
"""

from __future__ import annotations

import io
from fractions import Fraction

import numpy as np
import pytest

from posgmc.compiler import BuildOptions, BuildResult, ProgressMode, build_model
from posgmc.compiler.explore import _Progress
from posgmc.errors import BuildError, LimitError, PosgmcError
from posgmc.semantics.stages import instantiate
from posgmc.syntax.parser import parse_model


def build(text: str, **options: object) -> BuildResult:
    flat = instantiate(parse_model(text, file="m.prism"))
    return build_model(flat, options=BuildOptions(**options))  # type: ignore[arg-type]


def build_error(text: str, **options: object) -> BuildError:
    with pytest.raises(BuildError) as info:
        build(text, **options)
    return info.value


def row(model, c: int) -> dict[int, float]:  # type: ignore[no-untyped-def]
    T = model.transitions
    lo, hi = T.indptr[c], T.indptr[c + 1]
    return dict(zip(T.indices[lo:hi].tolist(), T.data[lo:hi].tolist()))


def valuation(model, s: int) -> dict[str, int]:  # type: ignore[no-untyped-def]
    return dict(zip(model.variable_names, model.state_values[s].tolist()))


# ---------------------------------------------------------------------------------------------
# exploration order, numbering, merging of duplicate targets
# ---------------------------------------------------------------------------------------------


def test_breadth_first_numbering_and_choice_order() -> None:
    # x counts up to 2; the unlabelled command comes before the labelled one of the same module
    # only by declaration order; [go] is shared by both modules, so it is synchronised and comes
    # after all non-synchronising choices (Storm's order)
    model = build(
        """mdp
module a
  x : [0..2];
  [go] x<2 -> (x'=x+1);
  [] x=0 -> (x'=2);
endmodule
module b
  [go] true -> true;
endmodule
"""
    ).model
    # state 0: x=0; choices: [] (to x=2: discovered first -> state 1), then [go] (x=1 -> state 2)
    assert model.num_states == 3
    assert [valuation(model, s)["x"] for s in range(3)] == [0, 2, 1]
    names = [model.action_names[a] for a in model.choice_actions]
    assert names[:2] == ["", "go"]
    assert row(model, 0) == {1: 1.0} and row(model, 1) == {2: 1.0}


def test_duplicate_targets_of_a_choice_are_merged() -> None:
    # 0.5:(x'=1) + 0.5:(x'=min(x+1,1)) both go to x=1 from x=0: one transition of probability 1
    model = build(
        """mdp
module m
  x : [0..1];
  [] x=0 -> 0.5:(x'=1) + 0.5:(x'=min(x+1,1));
  [] x=1 -> true;
endmodule
"""
    ).model
    assert (model.num_states, model.num_choices, model.num_transitions) == (2, 2, 2)
    assert row(model, 0) == {1: 1.0}


def test_zero_probability_branches_create_no_state() -> None:
    # the branch to x=2 has probability 0: Storm skips it before numbering its target
    model = build(
        """mdp
module m
  x : [0..2];
  [] x=0 -> 1:(x'=1) + 0:(x'=2);
  [] x>0 -> true;
endmodule
"""
    ).model
    assert model.num_states == 2 and model.num_transitions == 2


# ---------------------------------------------------------------------------------------------
# DTMC merging, synchronisation
# ---------------------------------------------------------------------------------------------


def test_dtmc_choices_are_merged_with_uniform_weights() -> None:
    # x=0 enables both commands: (0.5 x->1, 0.5 stay) and (x->1); merged with weight 1/2 each:
    # x->1 with 0.5*0.5 + 0.5*1 = 0.75, stay with 0.25
    model = build(
        """dtmc
module m
  x : [0..1];
  [] x=0 -> 0.5:(x'=1) + 0.5:true;
  [] x=0 -> (x'=1);
  [] x=1 -> true;
endmodule
"""
    ).model
    assert (model.num_states, model.num_choices, model.num_transitions) == (2, 2, 3)
    assert row(model, 0) == {0: 0.25, 1: 0.75}


def test_dtmc_action_rewards_are_averaged_over_merged_choices() -> None:
    # Storm: reward of the merged choice = sum of the choices' rewards / number of choices:
    # ([a] 2 + [b] 0) / 2 = 1
    model = build(
        """dtmc
module m
  x : [0..1];
  [a] x=0 -> (x'=1);
  [b] x=0 -> true;
  [] x=1 -> true;
endmodule
rewards "r"
  [a] true : 2;
endrewards
"""
    ).model
    assert model.reward_model("r").choice.tolist() == [1.0, 0.0]
    # the merged choice has two different actions: it is unlabelled
    assert model.choice_actions.tolist() == [0, 0]


def test_synchronisation_takes_all_combinations_and_multiplies_probabilities() -> None:
    # [s]: module a has two enabled commands, module b one with two branches: 2 choices of
    # 2 transitions each; probabilities multiply (1 * 0.3, 1 * 0.7)
    model = build(
        """mdp
module a
  x : [0..2];
  [s] x=0 -> (x'=1);
  [s] x=0 -> (x'=2);
endmodule
module b
  y : [0..1];
  [s] y=0 -> 0.3:(y'=1) + 0.7:true;
endmodule
"""
    ).model
    rg = model.row_groups
    assert rg[1] - rg[0] == 2
    probs = sorted(p for c in range(2) for p in row(model, c).values())
    assert probs == pytest.approx([0.3, 0.3, 0.7, 0.7])
    # successors of state 0 in order: (x=1,y=1), (x=1,y=0), (x=2,y=1), (x=2,y=0)
    assert [tuple(valuation(model, s).values()) for s in range(1, 5)] == [
        (1, 1),
        (1, 0),
        (2, 1),
        (2, 0),
    ]


def test_a_module_without_an_enabled_command_blocks_the_action() -> None:
    # b has [s] in its alphabet but its only [s] command needs y=1: [s] is never enabled, state
    # x=0 is a deadlock
    result = build(
        """mdp
module a
  x : [0..1];
  [s] x=0 -> (x'=1);
endmodule
module b
  y : [0..1];
  [s] y=1 -> true;
endmodule
"""
    )
    assert result.model.num_states == 1
    assert result.model.deadlocks.tolist() == [0]


def test_synchronised_modules_assigning_one_global_is_an_error() -> None:
    err = build_error(
        """mdp
global g : [0..2];
module a
  x : [0..1];
  [s] x=0 -> (x'=1)&(g'=1);
endmodule
module b
  y : [0..1];
  [s] y=0 -> (y'=1)&(g'=2);
endmodule
"""
    )
    assert "variable 'g' is assigned by both module a and module b" in err.message
    assert "(g=0, x=0, y=0)" in err.message
    assert err.span is not None and (err.span.line, err.span.column) == (9, 3)


# ---------------------------------------------------------------------------------------------
# errors in commands
# ---------------------------------------------------------------------------------------------


def test_probabilities_not_summing_to_one() -> None:
    err = build_error(
        """mdp
module m
  x : [0..3];
  [] x<3 -> 0.5:(x'=x+1) + 0.4:true;
endmodule
"""
    )
    assert "sum to 0.9, not 1" in err.message and "in state (x=0)" in err.message
    assert err.span is not None and (err.span.line, err.span.column) == (4, 3)


def test_state_dependent_probabilities_checked_per_state() -> None:
    # (x+1)/4 + (1 - (x+1)/4) = 1 everywhere; (x+1)/4 + 1/2 only at x=1: first bad state x=0 (0.75)
    model = build(
        """mdp
module m
  x : [0..3];
  [] true -> (x+1)/4:(x'=min(x+1,3)) + 1-(x+1)/4:true;
endmodule
"""
    ).model
    assert model.num_states == 4
    err = build_error(
        """mdp
module m
  x : [0..3];
  [] true -> (x+1)/4:(x'=min(x+1,3)) + 1/2:true;
endmodule
"""
    )
    assert "sum to 0.75, not 1" in err.message and "(x=0)" in err.message


def test_negative_probability() -> None:
    err = build_error(
        """mdp
module m
  x : [0..3];
  [] true -> 1.5:(x'=1) + -0.5:(x'=2);
endmodule
"""
    )
    assert "update probability -0.5" in err.message and "negative" in err.message
    assert err.span is not None and (err.span.line, err.span.column) == (4, 27)


def test_assignment_out_of_range() -> None:
    err = build_error(
        """mdp
module m
  x : [0..3];
  [] true -> (x'=x+1);
endmodule
"""
    )
    # x=0,1,2 are fine; from x=3 the update writes 4
    assert "assigns 4 to 'x', outside its range [0..3]" in err.message
    assert "in state (x=3)" in err.message
    assert err.span is not None and (err.span.line, err.span.column) == (4, 14)


def test_out_of_range_value_of_a_zero_probability_branch_is_not_an_error() -> None:
    model = build(
        """mdp
module m
  x : [0..1];
  [] true -> 1:(x'=1) + 0:(x'=x+5);
endmodule
"""
    ).model
    assert model.num_states == 2


def test_failing_expression_names_the_state() -> None:
    err = build_error(
        """mdp
module m
  x : [0..2];
  [] true -> (x'=mod(x+1, x));
endmodule
"""
    )
    assert "mod() by a non-positive divisor (0)" in err.message and "(x=0)" in err.message
    assert err.span is not None and (err.span.line, err.span.column) == (4, 18)


def test_short_circuit_keeps_failing_operands_off_other_states() -> None:
    # mod(2, x) is only evaluated where x>0 holds (PRISM evaluates & lazily)
    model = build(
        """mdp
module m
  x : [0..2];
  [] x>0 & mod(2, x)=0 -> (x'=0);
  [] x=0 -> (x'=x+1);
endmodule
"""
    ).model
    assert model.num_states == 2


# ---------------------------------------------------------------------------------------------
# deadlocks, initial states, limits
# ---------------------------------------------------------------------------------------------

COUNTDOWN = """mdp
module m
  x : [0..2] init 2;
  [] x>0 -> (x'=x-1);
endmodule
"""


def test_deadlocks_get_self_loops() -> None:
    result = build(COUNTDOWN)
    model = result.model
    # x=2 -> x=1 -> x=0 (deadlock, state 2)
    assert model.deadlocks.tolist() == [2]
    assert model.labels["deadlock"].tolist() == [False, False, True]
    assert row(model, 2) == {2: 1.0}
    assert model.action_names[model.choice_actions[2]] == ""
    assert result.warnings == ("1 deadlock state fixed with self-loops",)


def test_deadlock_is_an_error_when_not_fixed() -> None:
    err = build_error(COUNTDOWN, fix_deadlocks=False)
    assert "deadlock" in err.message and "(x=0)" in err.message
    assert err.span is not None and err.span.line == 2


def test_init_block_gives_every_satisfying_valuation() -> None:
    model = build(
        """mdp
module m
  x : [0..3];
  b : bool;
  [] true -> true;
endmodule
init x<2 endinit
"""
    ).model
    # x in {0,1} times b in {false,true}, numbered in valuation order
    assert model.initial_states.tolist() == [0, 1, 2, 3]
    assert [tuple(model.state_values[s]) for s in range(4)] == [(0, 0), (0, 1), (1, 0), (1, 1)]
    assert model.labels["init"].tolist() == [True] * 4


def test_init_block_without_satisfying_valuation() -> None:
    err = build_error(
        """mdp
module m
  x : [0..3];
  [] true -> true;
endmodule
init x>5 endinit
"""
    )
    assert "no state satisfies the init predicate" in err.message
    assert err.span is not None and err.span.line == 6


def test_init_enumeration_limit() -> None:
    with pytest.raises(LimitError) as info:
        build(
            """mdp
module m
  x : [0..999];
  y : [0..999];
  [] true -> true;
endmodule
init x+y<3 endinit
""",
            initial_state_limit=1000,
        )
    assert "1,000,000 candidate valuations" in info.value.message


def test_init_pinned_variables_are_not_enumerated() -> None:
    # x=0 & y=5 pin both variables: 1 candidate, far below the limit
    model = build(
        """mdp
module m
  x : [0..99999];
  y : [0..99999];
  [] true -> true;
endmodule
init x=0 & y=5 endinit
""",
        initial_state_limit=10,
    ).model
    assert model.num_states == 1 and valuation(model, 0) == {"x": 0, "y": 5}


def test_state_limit() -> None:
    with pytest.raises(LimitError) as info:
        build(
            """mdp
module m
  x : [0..100];
  [] x<100 -> (x'=x+1);
endmodule
""",
            state_limit=10,
        )
    assert "state limit of 10 reached" in info.value.message


def test_progress_is_written_when_asked() -> None:
    stream = io.StringIO()
    progress = _Progress(ProgressMode.ALWAYS, stream)
    progress.update(10, 20, final=True)
    assert "20 states found" in stream.getvalue()
    quiet = io.StringIO()
    _Progress(ProgressMode.AUTO, quiet).update(10, 20, final=True)  # not a terminal
    assert quiet.getvalue() == ""


# ---------------------------------------------------------------------------------------------
# labels and rewards
# ---------------------------------------------------------------------------------------------


def test_labels_and_rewards() -> None:
    model = build(
        """mdp
module m
  x : [0..2];
  [a] x<2 -> (x'=x+1);
  [] x=2 -> (x'=0);
endmodule
label "top" = x=2;
rewards "r"
  x>0 : 1;
  x=2 : 10;
  [a] x=1 : 5;
  [] true : 3;
endrewards
rewards "s"
  true : 1;
endrewards
"""
    ).model
    assert model.labels["top"].tolist() == [False, False, True]
    r = model.reward_model("r")
    # state rewards: x=0: 0, x=1: 1, x=2: 1+10
    assert r.state.tolist() == [0.0, 1.0, 11.0]
    # choices: x=0 [a] (guard x=1 false) 0; x=1 [a] 5; x=2 [] 3
    assert r.choice.tolist() == [0.0, 5.0, 3.0]
    assert model.reward_model("s").choice is None


# ---------------------------------------------------------------------------------------------
# games
# ---------------------------------------------------------------------------------------------

GAME = """smg
player p1 m1 endplayer
player p2 [b] endplayer
global t : [0..1];
module m1
  x : [0..1];
  [] t=0 -> (t'=1);
  [] t=0 -> (x'=1-x)&(t'=1);
endmodule
module m2
  [b] t=1 -> (t'=0);
  [c] t=1 -> (t'=0);
endmodule
"""


def test_players_own_states_through_their_choices() -> None:
    model = build(GAME).model
    # t=0 states: p1's unlabelled choices; t=1 states: [b] of p2 next to unowned [c] (PRISM-games
    # lets the owned choice decide; Storm would reject the unowned [c])
    t = model.state_values[:, model.variable_names.index("t")]
    assert model.player_names == ("p1", "p2")
    assert (model.state_players == np.where(t == 0, 0, 1)).all()


def test_choices_of_two_players_in_one_state() -> None:
    err = build_error(GAME.replace("[b] t=1", "[b] true"))
    assert "has choices of two players, p1 and p2" in err.message and "(t=0, x=0)" in err.message
    assert err.span is not None and (err.span.line, err.span.column) == (11, 3)


def test_several_unowned_choices_in_one_state() -> None:
    err = build_error(GAME.replace("player p2 [b] endplayer", "player p2 endplayer"))
    assert "several choices ([b], [c]) not owned by any player" in err.message
    assert "(t=1, x=0)" in err.message
    assert err.span is not None and (err.span.line, err.span.column) == (11, 3)


def test_a_single_unowned_choice_goes_to_the_first_player() -> None:
    model = build(
        GAME.replace("player p2 [b] endplayer", "player p2 endplayer").replace(
            "  [c] t=1 -> (t'=0);\n", ""
        )
    ).model
    assert (model.state_players == 0).all()


# ---------------------------------------------------------------------------------------------
# observations
# ---------------------------------------------------------------------------------------------


def test_pomdp_observation_ids_by_first_appearance() -> None:
    model = build(
        """pomdp
observable "o" = x>=2;
module m
  x : [0..3];
  [go] x<3 -> (x'=x+1);
  [go] x=3 -> true;
endmodule
"""
    ).model
    (obs,) = model.observations
    assert obs.player == 0 and obs.names == ("o",)
    # x=0,1 -> o=false (id 0), x=2,3 -> o=true (id 1)
    assert obs.state_ids.tolist() == [0, 0, 1, 1]
    assert obs.values.tolist() == [[0], [1]]


def test_same_observation_needs_same_actions() -> None:
    err = build_error(
        """pomdp
observable "o" = x>=2;
module m
  x : [0..3];
  [go] x<3 -> (x'=x+1);
  [stop] x=3 -> true;
endmodule
"""
    )
    # x=2 offers [go], x=3 offers [stop]; both observe o=true
    assert "states (x=2) and (x=3) look the same to the agent" in err.message
    assert "[go] only in the first, [stop] only in the second" in err.message
    assert err.span is not None and (err.span.line, err.span.column) == (2, 1)


def test_posg_players_have_their_own_observations() -> None:
    model = build(
        """posg
player p1 m1 observables x endobservables endplayer
player p2 m2 observable "yy" = y>0; endplayer
global t : [0..1];
module m1
  x : [0..2];
  [] t=0 -> (x'=min(x+1,2))&(t'=1);
endmodule
module m2
  y : [0..2];
  [] t=1 -> 0.5:(y'=min(y+1,2))&(t'=0) + 0.5:(t'=0);
endmodule
"""
    ).model
    assert [o.player for o in model.observations] == [0, 1]
    assert model.observations[0].num_observations == 3  # x in {0,1,2}
    assert model.observations[1].num_observations == 2  # y>0 false/true
    # the check only concerns the owner's states: p2's states all offer [] anyway


def test_smg_top_level_observables_go_to_every_player() -> None:
    model = build(
        """smg
player p1 m1 endplayer
player p2 m2 endplayer
global t : [0..1];
observable "tt" = t;
module m1
  [] t=0 -> (t'=1);
endmodule
module m2
  [] t=1 -> (t'=0);
endmodule
"""
    ).model
    assert [o.player for o in model.observations] == [0, 1]
    assert model.observations[0].state_ids is model.observations[1].state_ids


def test_observations_can_be_skipped() -> None:
    model = build(
        """pomdp
observable "o" = x>=2;
module m
  x : [0..3];
  [go] x<3 -> (x'=x+1);
  [stop] x=3 -> true;
endmodule
""",
        build_observations=False,
    ).model
    assert model.observations == ()


def test_errors_render_with_file_and_position() -> None:
    err = build_error(COUNTDOWN.replace("x>0 -> (x'=x-1)", "true -> (x'=x-1)"))
    assert str(err).startswith("m.prism:4:")
    assert isinstance(err, PosgmcError)


def test_exact_probability_sums_from_decimal_literals() -> None:
    # 0.1 + 0.2 + 0.7 is exactly 1 as decimals (0.30000000000000004 + 0.7 in floats)
    model = build(
        """mdp
module m
  x : [0..3];
  [] x=0 -> 0.1:(x'=1) + 0.2:(x'=2) + 0.7:(x'=3);
  [] x>0 -> true;
endmodule
"""
    ).model
    assert sorted(row(model, 0).values()) == pytest.approx([0.1, 0.2, 0.7])
    assert Fraction(1, 10) + Fraction(2, 10) + Fraction(7, 10) == 1


def test_progress_through_build_model(capsys: pytest.CaptureFixture[str]) -> None:
    build(COUNTDOWN, progress=ProgressMode.ALWAYS)
    assert "exploring: 3 states found, 3 explored" in capsys.readouterr().err
    build(COUNTDOWN, progress=ProgressMode.NEVER)
    assert capsys.readouterr().err == ""


def test_validation_modes_build_the_same_model() -> None:
    from posgmc.compiler import ValidationMode

    a = build(COUNTDOWN, validation=ValidationMode.ALWAYS).model
    b = build(COUNTDOWN, validation=ValidationMode.NEVER).model
    assert a.num_transitions == b.num_transitions == 3
