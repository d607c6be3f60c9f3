"""Lower step bounds on P path formulas (``F>=k``, ``U[k1,k2]``, ``G>=k``, ...): hand-derived values
on small dtmc/mdp/smg, agreement with the co-safe LTL product (the independent oracle: the same
formula as a DFA, solved as reachability on the product), empty intervals, and the CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from posgmc import api
from posgmc.checking.property_checker import PropertyChecker, QueryValue
from posgmc.cli import main
from posgmc.engines import ltl
from posgmc.engines import objectives as obj
from posgmc.engines.options import Method, SolverOptions
from posgmc.engines.step_bounds import interval_reach_probability
from posgmc.errors import PosgmcError, SemanticError
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.semantics.evaluate import evaluate_constant
from posgmc.syntax import parser
from posgmc.syntax.ast import (
    Coalition,
    Direction,
    Expr,
    ModelType,
    ProbQuery,
    Unary,
    UnaryOp,
)
from tests.engines.engine_models import small_models

ROOT = Path(__file__).resolve().parents[2]
ROVER = ROOT / "models" / "rover.smg"
TOL = 1e-6

# ---------------------------------------------------------------------------------------------
# hand-built models (every state initial, so that the LTL product maps every state)
# ---------------------------------------------------------------------------------------------


def chain() -> ExplicitModel:
    """dtmc: s0 -> 1/2 s1 + 1/2 s2; s1 -> s3; s2 -> s2; s3 -> s0. a = {s3}, b = {s0, s1}.

    The only paths: from s0 either s0 s1 s3 s0 ... (a at t = 2, then every 3 steps with the coin
    repeated at each return to s0) or s0 s2 s2 ... (never a)."""
    T = [[0, 0.5, 0.5, 0], [0, 0, 0, 1], [0, 0, 1, 0], [1, 0, 0, 0]]
    return make_model(
        ModelType.DTMC,
        [0, 1, 2, 3, 4],
        T,
        initial_states=range(4),
        labels={"a": [0, 0, 0, 1], "b": [1, 1, 0, 0]},
    )


def wait_mdp() -> ExplicitModel:
    """mdp: s0: go -> 1/2 s1 + 1/2 s2, wait -> s0; s1 -> s0; s2 -> s2. a = {s1}.

    The maximiser wants ``a`` at a late step: it waits until the go lands exactly in the window,
    which needs a step counter (no memoryless strategy reaches the value)."""
    T = [[0, 0.5, 0.5], [1, 0, 0], [1, 0, 0], [0, 0, 1]]
    return make_model(
        ModelType.MDP,
        [0, 2, 3, 4],
        T,
        initial_states=range(3),
        choice_actions=[1, 2, 0, 0],
        action_names=("", "go", "wait"),
        labels={"a": [0, 1, 0]},
    )


def two_player() -> ExplicitModel:
    """smg: s0 (p0): left -> s1, right -> s2; s1 (p1): x -> s3, y -> 1/2 s3 + 1/2 s4;
    s2 (p1): -> 1/4 s3 + 3/4 s0; s3 (p0, a) -> s4; s4 (p0) -> s4."""
    T = np.zeros((7, 5))
    T[0, 1] = T[1, 2] = 1.0
    T[2, 3] = 1.0
    T[3, 3], T[3, 4] = 0.5, 0.5
    T[4, 3], T[4, 0] = 0.25, 0.75
    T[5, 4] = T[6, 4] = 1.0
    return make_model(
        ModelType.SMG,
        [0, 2, 4, 5, 6, 7],
        T,
        initial_states=range(5),
        state_players=[0, 1, 1, 0, 0],
        player_names=("p0", "p1"),
        labels={"a": [0, 0, 0, 1, 0]},
    )


# ---------------------------------------------------------------------------------------------
# helpers: the checker on a hand-built model, and the LTL-product oracle
# ---------------------------------------------------------------------------------------------


def _resolver(model: ExplicitModel):  # type: ignore[no-untyped-def]
    def resolve(c: Coalition | None) -> frozenset[int] | None:
        if c is None:
            return None
        names = model.player_names
        return frozenset(names.index(p.name) for p in c.players)  # type: ignore[arg-type]

    return resolve


def query(model: ExplicitModel, text: str) -> QueryValue:
    """The per-state answer of ``P..=? [ ... ]`` through the property checker."""
    q = parser.parse_property(text).expr
    assert isinstance(q, ProbQuery)
    checker = PropertyChecker(model, coalition_of=_resolver(model), scalar=evaluate_constant)
    return checker.query(q)


def maximize_of(model: ExplicitModel, text: str) -> np.ndarray:
    q = parser.parse_property(text).expr
    assert isinstance(q, ProbQuery)
    return obj.maximize_mask(
        model, direction=q.direction or Direction.MAX, coalition=_resolver(model)(q.coalition)
    )


def ltl_oracle(
    model: ExplicitModel, path: Expr, maximize: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Proven (lower, upper) of the path formula at every (initial) state via the DFA product; a
    formula that is not co-safe through its co-safe negation (as PRISM-games does)."""
    if not ltl.is_cosafe(path):
        lo, hi = ltl_oracle(model, Unary(UnaryOp.NOT, path), ~maximize)
        return 1.0 - hi, 1.0 - lo
    atoms = ltl.extract_atoms(path)
    dfa = ltl.to_dfa(path, atoms)
    if atoms:
        values = np.stack([model.label(a.name) for a in atoms])  # type: ignore[attr-defined]
    else:
        values = np.zeros((0, model.num_states), dtype=bool)
    prod = ltl.product(model, dfa, values)
    r = obj.reach_probability(prod.model, prod.accepting, maximize=maximize[prod.state_of])
    return r.lower[prod.initial_map], r.upper[prod.initial_map]


def agree(q: QueryValue, oracle: tuple[np.ndarray, np.ndarray]) -> None:
    """Both are proven intervals of the same number: they must overlap and be close."""
    lo, hi = oracle
    slack = 1e-9
    assert np.all(q.lower <= hi + slack), (q.lower, hi)
    assert np.all(lo <= q.upper + slack), (lo, q.upper)
    assert np.allclose(q.values, 0.5 * (lo + hi), atol=2 * TOL)


def path_of(text: str) -> Expr:
    q = parser.parse_property(text).expr
    assert isinstance(q, ProbQuery)
    return q.path


# ---------------------------------------------------------------------------------------------
# hand-derived values
# ---------------------------------------------------------------------------------------------

# chain(): the value at s0, s1, s2, s3, read off the two kinds of path in chain()'s docstring.
CHAIN_CASES = [
    # s0: a at t=2 (1/2); s1: a at t=1 (too early), then t=4 if the coin at t=2 says s1 (1/2);
    # s3: a at t=0, then t=3 with 1/2
    ('P=? [ F>=2 "a" ]', [0.5, 0.5, 0.0, 0.5]),
    # s0: the first a (t=2) is too early, the next at t=5 needs two coins: 1/4
    ('P=? [ F>=3 "a" ]', [0.25, 0.5, 0.0, 0.5]),
    ('P=? [ F>2 "a" ]', [0.25, 0.5, 0.0, 0.5]),  # >2 is >=3
    # exactly at t=2: only s0 (s1 is at s0 at t=2, s3 at s1 or s2)
    ('P=? [ F=2 "a" ]', [0.5, 0.0, 0.0, 0.0]),
    ('P=? [ F[2,2] "a" ]', [0.5, 0.0, 0.0, 0.0]),
    # t in [2,4]: s0 at t=2 (1/2); s1 at t=4 (1/2); s3 at t=3 (1/2)
    ('P=? [ F[2,4] "a" ]', [0.5, 0.5, 0.0, 0.5]),
    # b U>=1 a: s1 sees a at t=1 after b at t=0 (1); s3 is a at t=0 only, which is too early and
    # not b, so 0. s0: s0 s1 s3, b at t=0,1 (1/2)
    ('P=? [ "b" U>=1 "a" ]', [0.5, 1.0, 0.0, 0.0]),
    ('P=? [ "b" U>0 "a" ]', [0.5, 1.0, 0.0, 0.0]),
    # b U>=2 a: s1 would need b at t=1 (s3): 0
    ('P=? [ "b" U>=2 "a" ]', [0.5, 0.0, 0.0, 0.0]),
    ('P=? [ "b" U[2,3] "a" ]', [0.5, 0.0, 0.0, 0.0]),
    # a lower bound of 0 is no bound at all
    ('P=? [ F>=0 "a" ]', [0.5, 1.0, 0.0, 1.0]),
    ('P=? [ F[0,1] "a" ]', [0.0, 1.0, 0.0, 1.0]),
]


@pytest.mark.parametrize("text, expected", CHAIN_CASES)
def test_chain_hand_values(text: str, expected: list[float]) -> None:
    m = chain()
    assert (m.num_states, m.num_choices, m.num_transitions) == (4, 4, 5)
    q = query(m, text)
    assert np.allclose(q.values, expected, atol=TOL)
    assert np.all(q.lower <= q.values) and np.all(q.values <= q.upper)


# wait_mdp(), value at s0, s1, s2. Tail v0 = Pmax[F a] = (1/2, 1, 0) (go from s0: 1/2, wait
# loops); one restricted step: v(s0) = max(1/2 v(s1) + 1/2 v(s2), v(s0)), v(s1) = v(s0),
# v(s2) = v(s2).
WAIT_CASES = [
    # v1 = (max(1/2, 1/2), 1/2, 0); v2 = (max(1/4, 1/2), 1/2, 0): wait once, then go
    ('Pmax=? [ F>=2 "a" ]', [0.5, 0.5, 0.0]),
    ('Pmax=? [ F>=5 "a" ]', [0.5, 0.5, 0.0]),
    # the minimiser waits forever: 0 everywhere (s1 is at s0 after one step)
    ('Pmin=? [ F>=2 "a" ]', [0.0, 0.0, 0.0]),
    # exactly at t=2: tail a = (0,1,0); v1 = (1/2, 0, 0); v2 = (max(0, 1/2), 1/2, 0)
    ('Pmax=? [ F=2 "a" ]', [0.5, 0.5, 0.0]),
    # G through the complement: Pmin[G>=1 !a] = 1 - Pmax[F>=1 a], Pmax[F>=1 a] = v1 = (1/2, 1/2, 0)
    ('Pmin=? [ G>=1 !"a" ]', [0.5, 0.5, 1.0]),
    ('Pmin=? [ G>0 !"a" ]', [0.5, 0.5, 1.0]),
    # Pmax[F[1,2] a]: tail Pmax[F<=1 a] = (1/2, 1, 0); one step: (1/2, 1/2, 0)
    ('Pmin=? [ G[1,2] !"a" ]', [0.5, 0.5, 1.0]),
    # Pmax[G>=1 !a] = 1 - Pmin[F>=1 a] = 1 - 0: the maximiser waits forever
    ('Pmax=? [ G>=1 !"a" ]', [1.0, 1.0, 1.0]),
]


@pytest.mark.parametrize("text, expected", WAIT_CASES)
def test_mdp_hand_values(text: str, expected: list[float]) -> None:
    m = wait_mdp()
    assert (m.num_states, m.num_choices, m.num_transitions) == (3, 4, 5)
    q = query(m, text)
    assert np.allclose(q.values, expected, atol=TOL)
    assert np.all(q.lower <= q.values + 1e-12) and np.all(q.values <= q.upper + 1e-12)


# two_player(), value at s0..s4. Unbounded tail v0 = <<p0>>P[F a] = (1, 1/2, 1, 1, 0) (right
# loops back to s0 until s3 is hit). Restricted steps: s0 max(s1, s2); s1 min(s3, (s3 + s4)/2);
# s2 s3/4 + 3 s0/4; s3 s4; s4 s4.
GAME_CASES = [
    # v1 = (1, 1/2, 1, 0, 0); v2 = (max(1/2, 1), min(0, 0), 3/4, 0, 0)
    ('<<p0>> Pmax=? [ F>=2 "a" ]', [1.0, 0.0, 0.75, 0.0, 0.0]),
    # tail a = (0,0,0,1,0); v1 = (0, min(1, 1/2), 1/4, 0, 0); v2 = (max(1/2, 1/4), 0, 0, 0, 0)
    ('<<p0>> Pmax=? [ F=2 "a" ]', [0.5, 0.0, 0.0, 0.0, 0.0]),
    # both maximise: v1 = (0, 1, 1/4, 0, 0); v2 = (1, 0, 0, 0, 0)
    ('<<p0,p1>> Pmax=? [ F=2 "a" ]', [1.0, 0.0, 0.0, 0.0, 0.0]),
    # p0 minimises: v2(s0) = min(1, 1/4)
    ('<<p1>> Pmax=? [ F=2 "a" ]', [0.25, 0.0, 0.0, 0.0, 0.0]),
]


@pytest.mark.parametrize("text, expected", GAME_CASES)
def test_game_hand_values(text: str, expected: list[float]) -> None:
    m = two_player()
    assert (m.num_states, m.num_choices, m.num_transitions) == (5, 7, 9)
    q = query(m, text)
    assert np.allclose(q.values, expected, atol=TOL)


# ---------------------------------------------------------------------------------------------
# agreement with the co-safe LTL product on the same formula
# ---------------------------------------------------------------------------------------------

FORMULAS = [
    'F>=3 "a"',
    'F>2 "a"',
    'F[1,3] "a"',
    'F=2 "a"',
    '"b" U>=2 "a"',
    '"b" U>1 "a"',
    '"b" U[2,4] "a"',
    'G>=2 !"a"',
    'G[1,3] !"a"',
    '"b" W>=2 "a"',
    '"b" W[1,2] "a"',
    '"b" R>=1 "a"',
    '"b" R[1,3] "a"',
]


def _with_b(model: ExplicitModel, b: list[int]) -> ExplicitModel:
    return make_model(
        model.model_type,
        model.row_groups,
        model.transitions,
        initial_states=model.initial_states,
        state_players=model.state_players if model.model_type.is_game else None,
        player_names=model.player_names,
        labels={"a": model.label("a"), "b": b},
    )


MODELS = {
    "chain": lambda: chain(),
    "mdp": lambda: _with_b(wait_mdp(), [1, 1, 0]),
    "smg": lambda: _with_b(two_player(), [1, 1, 0, 0, 1]),
}


PREFIXES = {
    "chain": ["P=?"],
    "mdp": ["Pmax=?", "Pmin=?"],
    "smg": ["Pmax=?", "Pmin=?", "<<p0>> Pmax=?", "<<p1>> Pmax=?"],
}
AGREEMENT_CASES = [
    (name, formula, prefix)
    for name in sorted(MODELS)
    for formula in FORMULAS
    for prefix in PREFIXES[name]
]


@pytest.mark.parametrize("name, formula, prefix", AGREEMENT_CASES)
def test_agrees_with_ltl_product(name: str, formula: str, prefix: str) -> None:
    m = MODELS[name]()
    text = f"{prefix} [ {formula} ]"
    agree(query(m, text), ltl_oracle(m, path_of(text), maximize_of(m, text)))


@st.composite
def labelled_models(draw: st.DrawFn) -> ExplicitModel:
    m = draw(small_models(max_states=5))
    S = m.num_states
    a = draw(st.lists(st.booleans(), min_size=S, max_size=S))
    b = draw(st.lists(st.booleans(), min_size=S, max_size=S))
    return make_model(
        m.model_type,
        m.row_groups,
        m.transitions,
        initial_states=range(S),
        state_players=m.state_players if m.model_type.is_game else None,
        player_names=m.player_names,
        labels={"a": a, "b": b},
    )


@st.composite
def bounds(draw: st.DrawFn) -> str:
    lo = draw(st.integers(0, 4))
    kind = draw(st.sampled_from([">=", ">", "[]", "="]))
    if kind == "[]":
        return f"[{lo},{lo + draw(st.integers(0, 3))}]"
    return f"{kind}{lo}"


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    model=labelled_models(),
    bound=bounds(),
    template=st.sampled_from(['F{} "a"', '"b" U{} "a"', 'G{} "b"', '"b" W{} "a"', '"a" R{} "b"']),
    prefix=st.sampled_from(["Pmax=?", "Pmin=?", "<<p0>> Pmax=?", "<<p1>> Pmin=?"]),
)
def test_random_models_agree_with_ltl_product(
    model: ExplicitModel, bound: str, template: str, prefix: str
) -> None:
    if "<<" in prefix and not model.model_type.is_game:
        prefix = "Pmax=?"
    text = f"{prefix} [ {template.format(bound)} ]"
    agree(query(model, text), ltl_oracle(model, path_of(text), maximize_of(model, text)))


@settings(max_examples=40, deadline=None)
@given(model=labelled_models(), data=st.data())
def test_engine_random_directions_agree_with_ltl_product(
    model: ExplicitModel, data: st.DataObject
) -> None:
    # a direction per state, also on an mdp (then it is a game the engine must still solve)
    S = model.num_states
    mx = np.array(data.draw(st.lists(st.booleans(), min_size=S, max_size=S)))
    lo = data.draw(st.integers(1, 4))
    hi = data.draw(st.one_of(st.none(), st.integers(lo, lo + 3)))
    bound = f">={lo}" if hi is None else f"[{lo},{hi}]"
    r = interval_reach_probability(
        model,
        model.label("a"),
        remain=model.label("b"),
        lower_steps=lo,
        upper_steps=hi,
        maximize=mx,
    )
    assert r.strategy is None
    assert np.all(r.lower <= r.upper)
    q = QueryValue(r.values, r.lower, r.upper)
    agree(q, ltl_oracle(model, path_of(f'P=? [ "b" U{bound} "a" ]'), mx))


# ---------------------------------------------------------------------------------------------
# the engine function itself
# ---------------------------------------------------------------------------------------------


def test_engine_lower_zero_is_the_plain_objective() -> None:
    m = wait_mdp()
    a, mx = m.label("a"), np.ones(3, dtype=bool)
    unbounded = interval_reach_probability(m, a, lower_steps=0, upper_steps=None, maximize=mx)
    direct = obj.reach_probability(m, a, maximize=mx)
    assert np.array_equal(unbounded.values, direct.values)
    assert unbounded.strategy is not None  # memoryless suffices without a lower bound
    bounded = interval_reach_probability(m, a, lower_steps=0, upper_steps=3, maximize=mx)
    direct_bounded = obj.bounded_reach_probability(m, a, steps=3, maximize=mx)
    assert np.array_equal(bounded.values, direct_bounded.values)


def test_engine_bounds_and_provenance() -> None:
    m = wait_mdp()
    a, mx = m.label("a"), np.ones(3, dtype=bool)
    r = interval_reach_probability(m, a, lower_steps=4, upper_steps=None, maximize=mx)
    tail = obj.reach_probability(m, a, maximize=mx)
    assert r.strategy is None
    assert r.iterations == tail.iterations + 4
    assert r.sound and r.converged and r.method is Method.INTERVAL
    assert np.all(r.lower <= r.values) and np.all(r.values <= r.upper)
    # the step is non-expansive: the gap does not grow
    assert np.max(r.upper - r.lower) <= np.max(tail.upper - tail.lower) + 1e-15
    value = interval_reach_probability(
        m,
        a,
        lower_steps=2,
        upper_steps=None,
        maximize=mx,
        options=SolverOptions(method=Method.VALUE),
    )
    assert not value.sound
    assert np.allclose(value.values, [0.5, 0.5, 0.0], atol=TOL)


def test_engine_empty_remain_gives_zero() -> None:
    m = chain()
    r = interval_reach_probability(
        m, m.label("a"), remain=np.zeros(4, dtype=bool), lower_steps=1, upper_steps=3,
        maximize=np.ones(4, dtype=bool),
    )
    assert np.array_equal(r.values, np.zeros(4))


def test_engine_rejects_bad_arguments() -> None:
    m = chain()
    a, mx = m.label("a"), np.ones(4, dtype=bool)
    with pytest.raises(PosgmcError, match="empty"):
        interval_reach_probability(m, a, lower_steps=3, upper_steps=2, maximize=mx)
    with pytest.raises(PosgmcError, match="non-negative"):
        interval_reach_probability(m, a, lower_steps=-1, upper_steps=None, maximize=mx)
    with pytest.raises(PosgmcError, match="one entry per state"):
        interval_reach_probability(m, a[:2], lower_steps=1, upper_steps=None, maximize=mx)


# ---------------------------------------------------------------------------------------------
# end to end: PRISM text, the LTL path as oracle, empty intervals, the CLI
# ---------------------------------------------------------------------------------------------

CHAIN_PRISM = """dtmc
module m
  s : [0..3] init 0;
  [] s=0 -> 0.5:(s'=1) + 0.5:(s'=2);
  [] s=1 -> (s'=3);
  [] s=2 -> (s'=2);
  [] s=3 -> (s'=0);
endmodule
label "a" = s=3;
"""

WAIT_PRISM = """mdp
const int k = 2;
module m
  s : [0..2] init 0;
  [go] s=0 -> 0.5:(s'=1) + 0.5:(s'=2);
  [wait] s=0 -> (s'=0);
  [] s=1 -> (s'=0);
  [] s=2 -> (s'=2);
endmodule
label "a" = s=1;
"""


def _values(text: str, props: list[str], *, path: Path | None = None) -> list[float]:
    session = api.load(path) if path is not None else api.load(text=text)
    report = api.check(session, properties=props)
    assert not report.errors, [e.render() for _, e in report.errors]
    return [float(r.value) for r in report.results]


@pytest.mark.parametrize(
    "bounded, cosafe, expected",
    [
        # chain(): see CHAIN_CASES; X X X F a: the path formula shifted by three steps
        ('P=? [ F>=3 "a" ]', 'P=? [ X X X F "a" ]', 0.25),
        ('P=? [ F>=2 "a" ]', 'P=? [ X X F "a" ]', 0.5),
        ('P=? [ F[2,4] "a" ]', 'P=? [ X X (F<=2 "a") ]', 0.5),
        ('P=? [ F=2 "a" ]', 'P=? [ X X "a" ]', 0.5),
        # G>=1 (s!=2): the complement of F>=1 s=2, which happens almost surely
        ('P=? [ G>=1 s!=2 ]', 'P=? [ X G s!=2 ]', 0.0),
    ],
)
def test_dtmc_text_matches_cosafe_form(bounded: str, cosafe: str, expected: float) -> None:
    got, oracle = _values(CHAIN_PRISM, [bounded, cosafe])
    assert got == pytest.approx(expected, abs=TOL)
    assert oracle == pytest.approx(expected, abs=2 * TOL)


@pytest.mark.parametrize(
    "bounded, cosafe, expected",
    [
        # wait_mdp(): WAIT_CASES
        ('Pmax=? [ F>=k "a" ]', 'Pmax=? [ X X F "a" ]', 0.5),
        ('Pmin=? [ F>=k "a" ]', 'Pmin=? [ X X F "a" ]', 0.0),
        ('Pmin=? [ G>=1 !"a" ]', 'Pmin=? [ X G !"a" ]', 0.5),
        ('Pmax=? [ F=k "a" ]', 'Pmax=? [ X X "a" ]', 0.5),
    ],
)
def test_mdp_text_matches_cosafe_form(bounded: str, cosafe: str, expected: float) -> None:
    got, oracle = _values(WAIT_PRISM, [bounded, cosafe])
    assert got == pytest.approx(expected, abs=TOL)
    assert oracle == pytest.approx(expected, abs=2 * TOL)


def _shifted(k: int, rest: str, *, invariant: str | None = None) -> str:
    """``X X .. X rest`` (k times), with ``invariant`` required at each of the k skipped steps."""
    for _ in range(k):
        rest = f"X ({rest})" if invariant is None else f"{invariant} & (X ({rest}))"
    return rest


@pytest.mark.parametrize(
    "prefix, bounded, cosafe, expected",
    [
        # 4 forward moves in the rover's 4 turns (steps 0, 2, 4, 6), the attacker spoofing twice:
        # 0.9^2 (honest) * 0.5^2 (spoofed) = 0.2025
        ("<<rover>> Pmax=?", 'F=8 "goal"', _shifted(8, '"goal"'), 0.2025),
        ("<<rover>> Pmax=?", 'F[8,10] "goal"', _shifted(8, 'F<=2 "goal"'), None),
        ("<<rover>> Pmax=?", 'F>=9 "goal"', _shifted(9, 'F "goal"'), None),
        ("<<rover,attacker>> Pmax=?", 'F[4,7] "crash"', _shifted(4, 'F<=3 "crash"'), None),
        (
            "<<rover>> Pmax=?",
            '!"crash" U[8,12] "goal"',
            _shifted(8, '!"crash" U<=4 "goal"', invariant='!"crash"'),
            None,
        ),
        ("<<rover>> Pmin=?", 'G>=4 !"crash"', _shifted(4, 'G !"crash"'), None),
    ],
)
def test_rover_game_matches_cosafe_form(
    prefix: str, bounded: str, cosafe: str, expected: float | None
) -> None:
    assert api.build(api.load(ROVER)).model.num_states == 60
    got, oracle = _values("", [f"{prefix} [ {bounded} ]", f"{prefix} [ {cosafe} ]"], path=ROVER)
    assert 0.0 < got  # not a trivial agreement
    assert got == pytest.approx(oracle, abs=2 * TOL)
    if expected is not None:
        assert got == pytest.approx(expected, abs=TOL)


@pytest.mark.parametrize(
    "prop, column, interval",
    [
        ('P=? [ F[3,2] "a" ]', 8, "[3, 2]"),
        ('P=? [ F<0 "a" ]', 8, "[0, -1]"),
        ('P=? [ "a" U[2,1] "a" ]', 12, "[2, 1]"),
        ('P=? [ G[5,4] "a" ]', 8, "[5, 4]"),
    ],
)
def test_empty_interval_is_rejected_with_position(prop: str, column: int, interval: str) -> None:
    # PRISM rejects these too ("Empty bound in ..."; IntegerBound.fromExpressionTemporal), and so
    # does the co-safe LTL translation: the same message here
    report = api.check(api.load(text=CHAIN_PRISM), properties=[prop])
    assert not report.results
    ((_, error),) = report.errors
    assert isinstance(error, SemanticError)
    assert f"interval {interval} is empty" in error.message
    assert error.span is not None and (error.span.line, error.span.column) == (1, column)


def test_cli_check_lower_bound(tmp_path: Path) -> None:
    model = tmp_path / "chain.pm"
    model.write_text(CHAIN_PRISM, encoding="utf-8")
    result = CliRunner().invoke(
        main, ["check", str(model), "--prop", 'P=? [ F>=2 "a" ]', "--json"], catch_exceptions=False
    )
    assert result.exit_code == 0, result.output
    (entry,) = json.loads(result.output)["results"]
    assert entry["value"] == pytest.approx(0.5, abs=TOL)  # chain(): CHAIN_CASES
    assert entry["sound"] is True


def test_weak_until_with_lower_bound_follows_prism() -> None:
    # PRISM rewrites a W[I] b as !((a & !b) U[I] (!a & !b)) (ExpressionTemporal's until form),
    # which differs from the textbook b R[I] (a | b) once there is a lower bound. Here a = b =
    # false on every state: (a & !b) fails at step 0, so the until fails and a W>=1 b holds (1),
    # where !b U>=1 (!a & !b) would hold and give 0. (The LTL translation reads W the same way;
    # the random tests above compare the two paths.)
    text = """dtmc
module m
  s : [0..1] init 0;
  [] true -> (s'=1);
endmodule
label "a" = false;
label "b" = false;
"""
    ours, prism_form = _values(
        text, ['P=? [ "a" W>=1 "b" ]', 'P=? [ !(("a" & !"b") U>=1 (!"a" & !"b")) ]']
    )
    assert (ours, prism_form) == (1.0, 1.0)
