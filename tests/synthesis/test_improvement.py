"""Observation-level policy iteration over deterministic FSSs (posgmc.synthesis.improvement), the
search start that gathers information where the projections of the full-observation optimum do
not: a hand-derived survey POMDP, the secure-autonomy case study at N=3, and on
small random POSGs its number is the strategy checker's value of its strategy and lies within the
brute-force range over every deterministic FSS."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from posgmc import api
from posgmc.checking.property_checker import CheckOptions, PropertyChecker
from posgmc.syntax import parser
from posgmc.synthesis.deterministic import _solve, quotient_of
from posgmc.synthesis.improvement import ImprovementJob, hole_scores, improve
from posgmc.synthesis.options import SynthesisOptions
from posgmc.synthesis.search import _projected, _qmdp, parametrisation, problem_of
from tests.random_games import random_posg
from tests.synthesis.helpers import every_deterministic, fss_guaranteed

ROOT = Path(__file__).resolve().parents[2]
SECURE = ROOT / "models" / "secure_autonomy" / "secure_autonomy.posg"

# By hand: nature hides a prize left or right (1/2 each). Surveying, the agent walks towards a
# sign (each walk survives with probability 0.9, else the run is lost) or commits; once committed
# it guesses left or right, and the run ends. It sees its position p, whether it has committed,
# and, on the sign (p=2), the prize's side. Committing at once wins 1/2; walking twice to the
# sign, committing and guessing the side seen wins 0.9 * 0.9 = 0.81, the optimum of the
# observation-based strategies (no other one does better: without the sign every guess wins 1/2).
# With full observation committing at once wins 1 (the guess would be right), so the
# full-observation optimum, its majority vote and the pessimistic QMDP all commit at once (Q of
# committing is 1 in every state of the first observation, of walking 0.9): 1/2.
SURVEY = """
pomdp
observables placed, p, seen, committed, over endobservables
module m
  side : [0..1] init 0;
  placed : bool init false;
  p : [0..2] init 0;    // 0 start, 1 half-way, 2 the sign
  seen : [0..2] init 0; // 0 nothing, 1 left, 2 right
  committed : bool init false;
  over : bool init false;
  won : bool init false;
  [place] !placed -> 0.5:(side'=0)&(placed'=true) + 0.5:(side'=1)&(placed'=true);
  [walk] placed & !over & !committed & p<2
    -> 0.9:(p'=p+1)&(seen'=(p+1=2 ? side+1 : 0)) + 0.1:(over'=true);
  [commit] placed & !over & !committed -> (committed'=true);
  [left] committed & !over -> (over'=true)&(won'=(side=0));
  [right] committed & !over -> (over'=true)&(won'=(side=1));
  [end] over -> true;
endmodule
label "won" = won;
"""


def _problem(session: api.Session, prop: str):  # type: ignore[no-untyped-def]
    model = api.build(session).model
    coalition_of = api._resolver(model, False).coalition_of
    expr = parser.parse_property(prop).expr
    players = coalition_of(expr.coalition)
    player = next(iter(players)) if players else 0
    adversary = (1 - player) if len(model.player_names) == 2 else None
    return problem_of(model, expr, player=player, adversary=adversary,
                      coalition_of=coalition_of, scalar=api._scalar)


def _start_value(problem, start) -> float:  # type: ignore[no-untyped-def]
    """The strategy checker's value of a start's hardened (deterministic) strategy."""
    par = parametrisation(problem, 1)
    g, d = par.hardened(*par.probabilities(*start))
    return fss_guaranteed(problem, 1, g, d)


def test_survey_pomdp_walks_to_the_sign() -> None:
    problem = _problem(api.load(text=SURVEY), 'Pmax=? [ F "won" ]')
    # the unplaced start, then per side: (p, seen) = (0,0), (1,0), (2,side+1), surveying or
    # committed (6); over after a failed walk from p = 0, 1 (2); over after a guess, won or
    # not, from p = 0..2 (6)
    assert problem.model.num_states == 1 + 2 * (6 + 2 + 6)
    # the projections of the full-observation optimum commit at once: 1/2 (by hand, above)
    par = parametrisation(problem, 1)
    full = PropertyChecker(problem.model, coalition_of=problem.coalition_of,
                           scalar=problem.scalar,
                           options=CheckOptions(keep_strategy=True)).query(problem.query)
    assert full.values[problem.model.initial_states[0]] == pytest.approx(1.0)
    assert _start_value(problem, _qmdp(par, full, problem.model, None, 1.0, 1.0)) == \
        pytest.approx(0.5)
    assert _start_value(problem, _projected(par, full, problem.model)) == pytest.approx(0.5)
    found = improve(problem, 1, deadline=None)
    assert found is not None
    assert found.value == pytest.approx(0.81, abs=1e-9)  # by hand, above
    # the strategy checker agrees on the defence found
    assert fss_guaranteed(problem, 1, found.gamma, found.delta) == pytest.approx(0.81, abs=1e-9)
    # it took the rounds of the hand derivation: commit everywhere (1/2), walk from the half-way
    # cell, walk from the start (0.81), then no change
    assert found.families == 3


def test_survey_pomdp_synthesis_reports_the_optimum() -> None:
    report = api.check(api.load(text=SURVEY), properties=['Pmax=? [ F "won" ]'],
                       synthesis=SynthesisOptions(memory=(1,), timeout=20, seed=0))
    r = report.results[0]
    assert r.full_observation.lower <= 1.0 <= r.full_observation.upper
    # proven bounds around 0.81 (by hand, above)
    assert r.guaranteed.lower <= 0.81 + 1e-9
    assert r.guaranteed.lower >= 0.81 - 1e-6


def test_secure_autonomy_n3_surveys_before_sending() -> None:
    """At N=3 (16,609 states, README's size table) the iteration reaches 0.8400598555, the
    full-observation value of `survey_then_retrieve` (README's results table: survey both areas,
    then retrieve), from starts that guarantee 0.25 (the blind guess)."""
    session = api.load(SECURE, constants={"N": "3", "flash": "false", "B": "1"})
    problem = _problem(session, '<<planner>> Pmax=? [ F "retrieved" ]')
    assert problem.model.num_states == 16_609
    found = improve(problem, 1, deadline=None)
    assert found is not None
    assert found.value == pytest.approx(0.8400598555, abs=1e-8)
    assert fss_guaranteed(problem, 1, found.gamma, found.delta) == pytest.approx(0.8400598555,
                                                                              abs=1e-8)


def test_larger_memory_is_never_worse() -> None:
    """Each size of the job starts from the best smaller defence too, and keeps it (embedded)
    when nothing better is found."""
    for seed in range(4):
        problem = _problem_random(seed, '<<p0>> Pmax=? [ F "goal" ]')
        results = ImprovementJob((1, 2), None).run(problem)
        assert [r.memory for r in results] == [1, 2]
        assert results[1].value >= results[0].value - 1e-9
        # the 2-node defence's number is its own value (checker), not the smaller one's alone
        assert fss_guaranteed(problem, 2, results[1].gamma, results[1].delta) == pytest.approx(
            results[1].value, abs=1e-7)


def _problem_random(seed: int, prop: str):  # type: ignore[no-untyped-def]
    model = random_posg(seed)
    coalition = api._resolver(model, False).coalition_of
    return problem_of(model, parser.parse_property(prop).expr, player=0, adversary=1,
                      coalition_of=coalition, scalar=api._scalar)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), maximize=st.booleans())
@example(seed=1833, maximize=False)  # an observation no state reaches: its first offered label
def test_value_is_the_checkers_and_within_brute_force(seed: int, maximize: bool) -> None:
    """Invariants: the number returned is what the strategy checker computes for the returned
    deterministic FSS (against the omniscient adversary), hence between the worst and the best
    deterministic memoryless FSS (brute force over all of them)."""
    prop = f'<<p0>> P{"max" if maximize else "min"}=? [ F "goal" ]'
    problem = _problem_random(seed, prop)
    found = improve(problem, 1, deadline=None)
    assert found is not None  # random_posg offers the same labels in every state of a view
    checked = fss_guaranteed(problem, 1, found.gamma, found.delta)
    assert found.value == pytest.approx(checked, abs=1e-7)
    values = [fss_guaranteed(problem, 1, g, d) for g, d in every_deterministic(problem, 1)]
    assert min(values) - 1e-7 <= checked <= max(values) + 1e-7


def test_hole_scores_mean_over_the_hole() -> None:
    """On the survey POMDP with the full-observation values, the first observation (placed, at
    the start) scores each guess-free option by its mean over the two sides: committing 1 (the
    full observation then guesses right), walking 0.9 (by hand: 0.9 times the half-way value 1)."""
    problem = _problem(api.load(text=SURVEY), 'Pmax=? [ F "won" ]')
    q = quotient_of(problem, 1)
    assert q is not None
    full = _solve(q, q.offered, None, problem)
    scores = hole_scores(q, full.values, problem)
    par = parametrisation(problem, 1)
    first = problem.model.transitions[problem.model.initial_states[0]].indices[0]
    z = int(par.obs_index[par.view.state_obs[first]])
    names = [problem.model.action_names[a] for a in par.used_actions]
    got = {names[o]: float(scores[z, o]) for o in range(len(names)) if np.isfinite(scores[z, o])}
    assert got == pytest.approx({"walk": 0.9, "commit": 1.0})


def test_a_passed_deadline_builds_no_quotient() -> None:
    """--memory 1..200 --timeout 3 ran over 110 s building quotients of k² rows after the budget
    was gone; now no size starts after the deadline, and no quotient is built past it."""
    import time

    from posgmc.synthesis.improvement import ImprovementJob
    from posgmc.synthesis.search import problem_of

    model = api.build(api.load(Path(__file__).resolve().parents[2] / "models" / "rover.posg")).model
    coalition_of = api._resolver(model, False).coalition_of
    problem = problem_of(model, parser.parse_property('<<rover>> Pmax=? [ F "goal" ]').expr,
                         player=0, adversary=1, coalition_of=coalition_of, scalar=api._scalar)
    past = time.perf_counter()
    assert quotient_of(problem, 200, deadline=past) is None
    assert ImprovementJob(tuple(range(1, 201)), past).run(problem) == ()
    q = quotient_of(problem, 2)
    assert q is not None and q.model.num_states > 0
