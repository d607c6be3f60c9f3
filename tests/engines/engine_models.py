"""Hand-built models and reference solvers shared by the engine tests."""

from __future__ import annotations

import itertools
from collections.abc import Callable
from fractions import Fraction

import numpy as np
from hypothesis import strategies as st

from posgmc.model.explicit import ExplicitModel, RewardModel, make_model
from posgmc.syntax.ast import ModelType


def smg_example() -> ExplicitModel:
    """tests/data/benchmarks/smg/smg_example/smg_example.prism, built by hand.

    Variables h, c in [0..2], initially 0. p1 owns module ``host`` and actions send1/send2; p2 owns
    module ``client``. With c=0 only host commands are enabled (p1's states), with c!=0 only the
    client's (p2's states). Reachable states, in (h, c) order:
    0:(0,0) p1: send1 -> 0.85 (1,1) + 0.15 (1,0); send2 -> 0.85 (2,2) + 0.15 (2,0); restart -> (0,0)
    1:(1,0) p1: restart -> (0,0)
    2:(1,1) p2: request -> (1,0); wait -> (1,1)
    3:(2,0) p1: restart -> (0,0)
    4:(2,2) p2: request -> (2,0); wait -> (2,2)
    5 states, 9 choices, 11 transitions (as in RESULTS.md: Storm 5 / 9 / 11).
    """
    T = np.zeros((9, 5))
    T[0, 2], T[0, 1] = 0.85, 0.15  # send1
    T[1, 4], T[1, 3] = 0.85, 0.15  # send2
    T[2, 0] = 1.0  # restart
    T[3, 0] = 1.0  # (1,0) restart
    T[4, 1] = 1.0  # (1,1) request
    T[5, 2] = 1.0  # (1,1) wait
    T[6, 0] = 1.0  # (2,0) restart
    T[7, 3] = 1.0  # (2,2) request
    T[8, 4] = 1.0  # (2,2) wait
    values = np.array([[0, 0], [1, 0], [1, 1], [2, 0], [2, 2]])
    return make_model(
        ModelType.SMG,
        [0, 3, 4, 6, 7, 9],
        T,
        state_players=[0, 0, 1, 0, 1],
        player_names=("p1", "p2"),
        variable_names=("h", "c"),
        state_values=values,
    )


def game_prism() -> ExplicitModel:
    """tests/data/benchmarks/smg/game/game.prism, built by hand (reward: 1 in every state).

    States (s, t): 0:(0,0) p1, 1:(1,0) p2, 2:(2,0) p1, 3:(3,0) p2, 4:(4,0) p1, 5:(5,0) p2,
    6:(0,1) p1 (self-loop), 7:(0,2) p1 (self-loop). In (k,0), k<5, the owner either advances to
    (k+1,0) or stops: ``(k+1)/10`` to (0,1) and the rest to (0,2); (5,0) moves to (0,1).
    8 states, 13 choices, 18 transitions (Storm: 8 / 13 / 18).
    """
    rows = []
    for k in range(5):
        adv = np.zeros(8)
        adv[k + 1] = 1.0
        stop = np.zeros(8)
        stop[6], stop[7] = (k + 1) / 10, 1 - (k + 1) / 10
        rows += [adv, stop]
    last = np.zeros(8)
    last[6] = 1.0
    loop6 = np.zeros(8)
    loop6[6] = 1.0
    loop7 = np.zeros(8)
    loop7[7] = 1.0
    rows += [last, loop6, loop7]
    rg = [0, 2, 4, 6, 8, 10, 11, 12, 13]
    return make_model(
        ModelType.SMG,
        rg,
        np.array(rows),
        state_players=[0, 1, 0, 1, 0, 1, 0, 0],
        player_names=("p1", "p2"),
        reward_models=(RewardModel(name=None, state=np.ones(8)),),
    )


# ---------------------------------------------------------------------------------------------
# random small models
# ---------------------------------------------------------------------------------------------


@st.composite
def small_models(
    draw: st.DrawFn, model_type: ModelType | None = None, max_states: int = 6
) -> ExplicitModel:
    """A random small model whose probabilities are multiples of 1/4 (exact in binary)."""
    mtype = model_type or draw(st.sampled_from([ModelType.DTMC, ModelType.MDP, ModelType.SMG]))
    S = draw(st.integers(1, max_states))
    counts = [1 if mtype is ModelType.DTMC else draw(st.integers(1, 3)) for _ in range(S)]
    rows = []
    for _ in range(sum(counts)):
        k = draw(st.integers(1, min(3, S)))
        succ = draw(st.lists(st.integers(0, S - 1), min_size=k, max_size=k, unique=True))
        quarters = draw(st.lists(st.integers(1, 4), min_size=len(succ), max_size=len(succ)))
        row = np.zeros(S)
        total = sum(quarters)
        for t, q in zip(succ, quarters):
            row[t] += q
        row /= total
        # round to multiples of 1/4 keeping the sum 1 (denominators stay powers of two)
        rows.append(_quarters(row, draw))
    rg = np.concatenate([[0], np.cumsum(counts)])
    players = [draw(st.integers(0, 1)) for _ in range(S)] if mtype is ModelType.SMG else None
    return make_model(
        mtype,
        rg,
        np.array(rows),
        state_players=players,
        player_names=("p0", "p1") if mtype is ModelType.SMG else (),
    )


def _quarters(row: np.ndarray, draw: st.DrawFn) -> np.ndarray:
    support = np.flatnonzero(row)
    out = np.zeros_like(row)
    remaining = 4
    for i, t in enumerate(support):
        if i == support.size - 1:
            out[t] = remaining / 4
        else:
            q = draw(st.integers(1, max(1, remaining - (support.size - 1 - i))))
            q = min(q, remaining - (support.size - 1 - i))
            if q <= 0:
                break
            out[t] = q / 4
            remaining -= q
    if out.sum() != 1.0:  # fewer quarters than successors: put everything on the first
        out = np.zeros_like(row)
        out[support[0]] = 1.0
    return out


# ---------------------------------------------------------------------------------------------
# reference solvers (brute force over memoryless deterministic profiles, floating point)
# ---------------------------------------------------------------------------------------------


def profiles(model: ExplicitModel) -> list[np.ndarray]:
    """Every memoryless deterministic profile (global choice per state)."""
    rg = model.row_groups
    ranges = [range(int(rg[s]), int(rg[s + 1])) for s in range(model.num_states)]
    return [np.array(p, dtype=np.int64) for p in itertools.product(*ranges)]


def chain_reach(model: ExplicitModel, rows: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Reach probability of the chain of ``rows`` (exact rationals, returned as floats)."""
    S = model.num_states
    P = model.transitions[rows].toarray()
    # states that can reach the target
    can = target.copy()
    for _ in range(S):
        can = can | ((P[:, can].sum(axis=1) > 0) & ~target)
    idx = np.flatnonzero(can & ~target)
    x = np.zeros(S)
    x[target] = 1.0
    if idx.size:
        A = np.eye(idx.size) - P[np.ix_(idx, idx)]
        b = P[np.ix_(idx, np.flatnonzero(target))].sum(axis=1)
        x[idx] = np.linalg.solve(A, b)
    return x


def chain_reward(
    model: ExplicitModel, rows: np.ndarray, rewards: np.ndarray, target: np.ndarray, mode: str
) -> np.ndarray:
    """Expected reward until ``target`` of the chain of ``rows``; mode "inf" (infinite unless
    reached almost surely) or "cum" (collect everything; target absorbing)."""
    S = model.num_states
    P = model.transitions[rows].toarray()
    r = rewards[rows].copy()
    P[target] = 0.0
    r[target] = 0.0
    for s in np.flatnonzero(target):
        P[s, s] = 1.0
    reach = (np.eye(S) + P) > 0  # reflexive one-step reachability, closed below
    for _ in range(S):
        reach = (reach.astype(int) @ reach.astype(int)) > 0
    x = np.zeros(S)
    if mode == "inf":
        probs = chain_reach(model, rows, target)
        inf = probs < 1 - 1e-12
        zero = target
    else:
        recurrent = np.array([all(reach[t, s] for t in range(S) if reach[s, t]) for s in range(S)])
        positive_rec = recurrent & np.array(
            [any(r[t] > 0 for t in range(S) if reach[s, t] and reach[t, s]) for s in range(S)]
        )
        inf = np.array([bool((reach[s] & positive_rec).any()) for s in range(S)])
        zero = (
            np.array([not any(r[t] > 0 for t in range(S) if reach[s, t]) for s in range(S)])
            | target
        )
    x[inf] = np.inf
    rest = np.flatnonzero(~inf & ~zero)
    if rest.size:
        A = np.eye(rest.size) - P[np.ix_(rest, rest)]
        x[rest] = np.linalg.solve(A, r[rest])
    return x


def game_value(
    model: ExplicitModel, maximize: np.ndarray, evaluate: Callable[[np.ndarray], np.ndarray]
) -> np.ndarray:
    """max over maximiser profiles of min over minimiser profiles, per state (brute force)."""
    rg = model.row_groups
    S = model.num_states
    max_states = [s for s in range(S) if maximize[s]]
    min_states = [s for s in range(S) if not maximize[s]]
    best = np.full(S, -np.inf)
    for pm in itertools.product(*[range(int(rg[s]), int(rg[s + 1])) for s in max_states]):
        worst = np.full(S, np.inf)
        for pn in itertools.product(*[range(int(rg[s]), int(rg[s + 1])) for s in min_states]):
            rows = np.zeros(S, dtype=np.int64)
            rows[max_states] = pm
            rows[min_states] = pn
            worst = np.minimum(worst, evaluate(rows))
        best = np.maximum(best, worst)
    return best


def as_floats(values: list[Fraction]) -> np.ndarray:
    return np.array([float(v) for v in values])


@st.composite
def layered_models(draw: st.DrawFn, max_states: int = 7) -> ExplicitModel:
    """A random model whose states come in groups (future SCCs, or trivial ones): every choice
    moves within its group, to an earlier group, or to the last two states (goal, sink; both
    absorbing). Probabilities are multiples of 1/4, so exact rationals apply."""
    mtype = draw(st.sampled_from([ModelType.DTMC, ModelType.MDP, ModelType.SMG]))
    n = draw(st.integers(2, max_states - 2))
    group = sorted(draw(st.lists(st.integers(0, 3), min_size=n, max_size=n)))
    S = n + 2
    counts = [1 if mtype is ModelType.DTMC else draw(st.integers(1, 2)) for _ in range(n)]
    rows = []
    for s in range(n):
        reach = [t for t in range(n) if group[t] <= group[s]] + [n, n + 1]
        for _ in range(counts[s]):
            k = draw(st.integers(1, 3))
            succ = draw(st.lists(st.sampled_from(reach), min_size=k, max_size=k))
            row = np.zeros(S)
            for t in succ:
                row[t] += 0.25
            row[succ[0]] += 1.0 - row.sum()
            rows.append(row)
    for t in (n, n + 1):
        row = np.zeros(S)
        row[t] = 1.0
        rows.append(row)
    rg = np.concatenate([[0], np.cumsum(counts + [1, 1])])
    players = [draw(st.integers(0, 1)) for _ in range(S)] if mtype is ModelType.SMG else None
    return make_model(
        mtype,
        rg,
        np.array(rows),
        state_players=players,
        player_names=("p0", "p1") if mtype is ModelType.SMG else (),
    )
