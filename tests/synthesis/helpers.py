"""Brute-force enumerations of deterministic strategies and small models shared by the synthesis
tests (the random games: :mod:`tests.random_games`)."""

from __future__ import annotations

import itertools

import numpy as np

from posgmc import api
from posgmc.strategies.fss import FiniteStateStrategy
from posgmc.strategies.verify import StrategyChecker
from posgmc.syntax import parser
from posgmc.synthesis.checker import SynthesisChecker
from posgmc.synthesis.options import SynthesisOptions
from posgmc.synthesis.problem import POLICY
from posgmc.synthesis.search import parametrisation, problem_of
from tests.conftest import BENCHMARKS

POSMG = BENCHMARKS / "posmg"
"""PAYNT's POSMGs (vendored; tests/data/README.md)."""

PROP = '<<p0>> Pmax=? [ F "goal" ]'
SMALL = SynthesisOptions(memory=(1,), restarts=1, iterations=10, timeout=120, adversaries=2,
                         compose_restarts=1)
"""Small enough to finish far within the budget (so runs are deterministic), on 3-7 states."""


def reach_problem(model):  # type: ignore[no-untyped-def]
    """The problem of :data:`PROP` on ``model``: p0 against p1."""
    coalition = api._resolver(model, False).coalition_of
    return problem_of(model, parser.parse_property(PROP).expr, player=0, adversary=1,
                      coalition_of=coalition, scalar=api._scalar)


def synthesised(model, options: SynthesisOptions = SMALL):  # type: ignore[no-untyped-def]
    """:data:`PROP` on ``model`` answered by synthesis with ``options``."""
    checker = SynthesisChecker(model, coalition_of=api._resolver(model, False).coalition_of,
                               scalar=api._scalar, synthesis=options)
    return checker.check(parser.parse_property(PROP).expr, text=PROP)


def without_times(doc: dict) -> dict:  # type: ignore[type-arg]
    """A result's synthesis statistics without what depends on time or placement."""
    # "synthesis": where the jobs ran and their times (the task counts: test_jobs_... below)
    out = {k: v for k, v in doc.items() if k not in ("seconds", "phases", "synthesis")}
    out["rounds"] = [{k: v for k, v in r.items() if k != "seconds"} for r in doc["rounds"]]
    out["deterministic"] = [{k: v for k, v in r.items() if k != "seconds"}
                            for r in doc.get("deterministic", [])]
    return out


def deterministic_strategies(model, player: int, observables, values, offered):  # type: ignore[no-untyped-def]
    """Every deterministic memoryless FSS over the given observations and offered labels."""
    labels = sorted({a for row in offered for a in row})
    for pick in itertools.product(*offered):
        gamma = np.zeros((1, len(values), len(labels)))
        for i, a in enumerate(pick):
            gamma[0, i, labels.index(a)] = 1.0
        yield FiniteStateStrategy.from_arrays(player=player, observables=observables,
                                              observation_values=values, actions=tuple(labels),
                                              action=gamma)


def labels_by_observation(model, player: int, ids: np.ndarray) -> list[list[str]]:  # type: ignore[no-untyped-def]
    """For each observation id of ``player``, the action labels offered there (first state)."""
    out = []
    for z in range(int(ids.max()) + 1):
        states = np.flatnonzero((model.state_players == player) & (ids == z))
        if states.size == 0:
            out.append([])
            continue
        s = int(states[0])
        out.append([model.action_names[model.choice_actions[c]]
                    for c in range(model.row_groups[s], model.row_groups[s + 1])])
    return out


def fss_guaranteed(problem, memory: int, gamma: np.ndarray, delta: np.ndarray) -> float:  # type: ignore[no-untyped-def]
    """What the FSS (γ, δ) ensures against the omniscient adversary: the strategy checker's
    policy iteration on its product (independent of the quotient game)."""
    fss = parametrisation(problem, memory).strategy(gamma, delta)
    r = StrategyChecker(problem.model, {fss.player: fss}, coalition_of=problem.coalition_of,
                        scalar=problem.scalar, options=POLICY).check(problem.query, text="brute")
    assert r.guaranteed is not None
    return float(r.guaranteed.value)


def runner_crossing_at_once(problem) -> float:  # type: ignore[no-untyped-def]
    """What the memoryless runner of the lanes games (tests/data/games/dodge_lanes*.posg) that
    crosses left or right with probability 1/2 is verified to ensure against every guard."""
    from posgmc.synthesis import belief_dynamics

    dyn = belief_dynamics.Dynamics(problem, None)
    names = [problem.model.action_names[a] for a in dyn.actions.tolist()]
    gamma = np.zeros((1,) + dyn.mask.shape)
    for z in range(dyn.mask.shape[0]):
        cross = [a for a, name in enumerate(names) if name in ("left", "right") and dyn.mask[z, a]]
        for a in cross or np.flatnonzero(dyn.mask[z]).tolist()[:1]:
            gamma[0, z, a] = 1.0 / max(1, len(cross))
    return fss_guaranteed(problem, 1, gamma, np.ones(gamma.shape + (1,)))


def every_deterministic(problem, memory: int):  # type: ignore[no-untyped-def]
    """(γ, δ) of every deterministic ``memory``-node FSS of the decision maker (node 0 initial)."""
    mask = parametrisation(problem, memory).mask
    Zu, Au = mask.shape
    options = [[(a, n) for a in np.flatnonzero(mask[z]).tolist() for n in range(memory)]
               for _ in range(memory) for z in range(Zu)]
    for pick in itertools.product(*options):
        gamma = np.zeros((memory, Zu, Au))
        delta = np.zeros((memory, Zu, Au, memory))
        for i, (a, n) in enumerate(pick):
            gamma[i // Zu, i % Zu, a] = 1.0
            delta[i // Zu, i % Zu, :, n] = 1.0
        yield gamma, delta


# by hand: the agent cannot see whether it is in s=0, s=1 or s=2 (from s=0 either action moves
# to s=1 or s=2, 1/2 each, for free); "a" reaches the goal from s=1 (cost
# 1) and loops in s=2, "b" the other way round. Every memoryless strategy that reaches the goal
# almost surely randomises: with P(a) = q the expected cost is 1/2 (1/q) + 1/2 (1/(1-q)), least at
# q = 1/2: Rmin = 2 (full observation: 1). A deterministic strategy's cost is infinite.
BLIND = """
pomdp
observables o endobservables
module m
  s : [0..3] init 0;
  o : [0..1] init 0;
  [a] s=0 -> 0.5:(s'=1) + 0.5:(s'=2);
  [b] s=0 -> 0.5:(s'=1) + 0.5:(s'=2);
  [a] s=1 -> (s'=3)&(o'=1);
  [b] s=1 -> (s'=1);
  [a] s=2 -> (s'=2);
  [b] s=2 -> (s'=3)&(o'=1);
  [a] s=3 -> true;
  [b] s=3 -> true;
endmodule
rewards "cost" [a] s=1|s=2 : 1; [b] s=1|s=2 : 1; endrewards
"""


# by hand: a coin in s=0 puts the agent in s=1 or s=2, which it cannot tell apart (o=0 in s=0..4).
# In s=1 "a" wins and "b" moves to s=3; in s=2 "b" wins and "a" moves to s=4; in s=3 "a" wins, in
# s=4 "b" wins, the other action loses (s=6). With memory: "a" first, and if the game goes on the
# agent is in s=4, where "b" wins: Pmax = 1. Memoryless with P(a) = q: 1/2 (q + (1-q) q) +
# 1/2 (q (1-q) + (1-q)) = 1/2 + q (1-q), at most 3/4 (q = 1/2); deterministic: 1/2.
GUESS = """
pomdp
observables o endobservables
module m
  s : [0..6] init 0;
  o : [0..2] init 0;
  [a] s=0 -> 0.5:(s'=1) + 0.5:(s'=2);
  [b] s=0 -> 0.5:(s'=1) + 0.5:(s'=2);
  [a] s=1 -> (s'=5)&(o'=1);
  [b] s=1 -> (s'=3);
  [a] s=2 -> (s'=4);
  [b] s=2 -> (s'=5)&(o'=1);
  [a] s=3 -> (s'=5)&(o'=1);
  [b] s=3 -> (s'=6)&(o'=2);
  [a] s=4 -> (s'=6)&(o'=2);
  [b] s=4 -> (s'=5)&(o'=1);
  [a] s>=5 -> true;
  [b] s>=5 -> true;
endmodule
label "goal" = s=5;
"""


# rewards of both signs: every choice outside s=4 stops with 1/10 (to s=4, the target), so every
# strategy's expected total reward is finite; s=1 and s=2 look alike, and the action that pays
# there (a in s=1, b in s=2) is the other one's loss, so the agent that cannot tell them apart
# earns less than full observation (7.04, the full-observation optimum from s=0)
SIGNED = """
pomdp
observables o endobservables
module m
  s : [0..4] init 0;
  o : [0..1] init 0;
  [a] s=0 -> 0.3:(s'=1) + 0.7:(s'=2);
  [b] s=0 -> 0.6:(s'=1) + 0.4:(s'=3);
  [a] s=1 -> 0.1:(s'=4)&(o'=1) + 0.6:(s'=2) + 0.3:(s'=3);
  [b] s=1 -> 0.1:(s'=4)&(o'=1) + 0.9:(s'=1);
  [a] s=2 -> 0.1:(s'=4)&(o'=1) + 0.9:(s'=1);
  [b] s=2 -> 0.1:(s'=4)&(o'=1) + 0.5:(s'=3) + 0.4:(s'=2);
  [a] s=3 -> 0.1:(s'=4)&(o'=1) + 0.9:(s'=2);
  [b] s=3 -> 0.1:(s'=4)&(o'=1) + 0.2:(s'=1) + 0.7:(s'=3);
  [a] s=4 -> true;
  [b] s=4 -> true;
endmodule
rewards "r"
  [a] s=0 : 0.1; [b] s=0 : -0.2;
  [a] s=1 : 0.7; [b] s=1 : -0.3;
  [a] s=2 : -0.5; [b] s=2 : 0.9;
  [a] s=3 : -0.1; [b] s=3 : 0.6;
endrewards
"""
