"""The one-sided approach (ACJJKT19) and the double oracle: the adversary's deterministic
k□-node strategies enumerated and ranked, the defence composed against the strongest, and the
adversary's best response to the composed defence added while it beats them.

1. **Rank.** Every enumerated adversary strategy a (:mod:`posgmc.synthesis.adversaries`) is
   ranked by its strength: the decision maker's full-information optimum against it,
   U(a) = opt over decision-maker strategies on the product of the model with a (an MDP solve;
   policy iteration). The lower U(a) (for a maximising decision maker), the stronger a; the M
   strongest are kept (``--adversaries M``); min over a of U(a) is ``upper_bound``.
2. **Compose.** With the kept adversaries a_1..a_M, the defence's randomised k-node FSS θ gives
   M parametric Markov chains (the product of the model with a_j, then with θ), values V_j(θ).
   Maximise min_j V_j(θ) (minimise max_j for Pmin/Rmin) by Adam on a smooth minimum: the
   gradient is Σ_j w_j ∇V_j(θ), w = softmin of the values with temperature 1e-3 (relative), i.e.
   the subgradient of the active adversary, shared between near-ties. ∇V_j is exact (the adjoint
   of :mod:`posgmc.synthesis.parametric` on the product with a_j). Starts: the search's defence
   (so the composed defence is at least as good against the kept set) and seeded random logits.
3. **Double oracle.** The adversary's best response to the composed defence: over every
   enumerated deterministic strategy when the enumeration was exhaustive and small
   (``RESPONSE_EXHAUSTIVE``), otherwise gradient synthesis of the adversary's k□-node FSS against
   the fixed defence (the product with the defence is a POMDP for the adversary). If it beats
   the kept set, it joins it and the defence is composed again, until nothing improves or the
   rounds (``oracle_rounds``) run out.

Each phase's extent is counted (strategies enumerated and ranked, gradient steps, MILP nodes,
rounds: :mod:`posgmc.synthesis.budget`); the ``deadline`` every phase looks at is the wall-clock
cap, which only a binding ``--timeout`` (or an interrupt) reaches.

Every evaluation is a job (:mod:`posgmc.synthesis.executors`), run in parallel with ``--jobs``. The
floats computed here rank and steer; the reported numbers are verified afterwards
(:func:`verified_numbers`) by the sound engines.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from posgmc.checking.property_checker import CheckOptions
from posgmc.checking.results import Bound
from posgmc.strategies.binding import bind
from posgmc.strategies.fss import FiniteStateStrategy
from posgmc.strategies.product import strategy_product
from posgmc.strategies.verify import StrategyChecker
from posgmc.synthesis import milp, progress
from posgmc.synthesis.adversaries import Enumeration, enumerate_adversaries
from posgmc.synthesis.ascent import LOGIT, ascend
from posgmc.synthesis.executors import Executor
from posgmc.synthesis.parametric import Layout, Parametrisation, game_views
from posgmc.synthesis.problem import POLICY, Problem, expired

__all__ = ["OneSided", "one_sided", "verified_numbers", "RankJob", "VersusJob", "ComposeJob",
           "ResponseJob", "RESPONSE_EXHAUSTIVE"]

RESPONSE_EXHAUSTIVE = 256
"""The double oracle's best response is exhaustive over the enumerated deterministic adversary
strategies when the enumeration was complete and found at most this many."""

_TEMPERATURE = 1e-3
"""The smooth minimum's temperature, relative to the value's magnitude."""


# -- jobs ------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class RankJob:
    """The decision maker's full-information optimum against ``adversary`` (policy iteration)."""

    PHASE: ClassVar[str] = "adversaries: ranking"

    adversary: FiniteStateStrategy

    def run(self, problem: Problem) -> float:
        r = StrategyChecker(problem.model, {self.adversary.player: self.adversary},
                            coalition_of=problem.coalition_of, scalar=problem.scalar,
                            options=POLICY).check(problem.query, text="rank")
        assert r.upper_bound is not None  # noqa: S101 - the adversary's strategy is given
        return float(r.upper_bound.value)


@dataclass(frozen=True, eq=False)
class VersusJob:
    """The value of the profile (``defence``, ``adversary``): a Markov chain's linear solve."""

    PHASE: ClassVar[str] = "adversaries: evaluation"

    defence: FiniteStateStrategy
    adversary: FiniteStateStrategy

    def run(self, problem: Problem) -> float:
        r = StrategyChecker(problem.model, {self.defence.player: self.defence,
                                            self.adversary.player: self.adversary},
                            coalition_of=problem.coalition_of, scalar=problem.scalar,
                            options=POLICY).check(problem.query, text="versus")
        assert r.vs_fss_adversary is not None  # noqa: S101 - both strategies are given
        return float(r.vs_fss_adversary.value)


@dataclass(frozen=True, eq=False)
class Composed:
    """A composed defence: its strategy, logits and min over the kept adversaries (float,
    from the decision maker's side: the smallest value for Pmax, the largest for Pmin)."""

    strategy: FiniteStateStrategy
    logits: tuple[np.ndarray, np.ndarray]
    value: float
    evaluations: int


@dataclass(frozen=True, eq=False)
class ComposeJob:
    """Adam on min_j V_j(θ) over ``adversaries`` from ``logits``; returns a :class:`Composed`
    (the best of the best iterate, its sharpened and its deterministic version)."""

    PHASE: ClassVar[str] = "adversaries: composition"

    adversaries: tuple[FiniteStateStrategy, ...]
    memory: int
    logits: tuple[np.ndarray, np.ndarray]
    iterations: int
    learning_rate: float
    deadline: float | None

    def run(self, problem: Problem) -> Composed:
        layout = Layout.of(problem.model, problem.player)
        pars = [_against(problem, a, self.memory, layout) for a in self.adversaries]
        sign = problem.sign

        def step(la: np.ndarray, ld: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
            g, d = pars[0].probabilities(la, ld)
            evs = [p.evaluate(g, d) for p in pars]
            vals = sign * np.array([ev.value for ev in evs])
            worst = float(vals.min())
            if np.isfinite(worst):
                tau = _TEMPERATURE * max(1.0, abs(worst))
                w = np.exp(-(vals - worst) / tau)
            else:
                w = (vals == worst).astype(np.float64)
            w /= w.sum()
            ga, gd = np.zeros_like(la), np.zeros_like(ld)
            for wj, ev, p in zip(w.tolist(), evs, pars):
                if wj > 0:
                    a, b = p.logit_gradient(ev, g, d)
                    ga += wj * a
                    gd += wj * b
            return worst, sign * ga, sign * gd

        (la, ld), reached, n = ascend(step, *self.logits, iterations=self.iterations,
                                      learning_rate=self.learning_rate, deadline=self.deadline)
        g, d = pars[0].probabilities(la, ld)
        if expired(self.deadline):
            # no time for the sharpened and deterministic versions (an evaluation against every
            # adversary each): the best iterate with the value the ascent measured (-inf, never
            # chosen, when it took no step)
            return Composed(pars[0].strategy(g, d), (la, ld), sign * reached, n)
        best: tuple[float, np.ndarray, np.ndarray] | None = None
        # the sharpened, then the deterministic version is kept unless a later one is better by
        # 1e-6 (relative): simpler, and verified far faster than the softmax's near-deterministic
        # loops
        for gg, dd in (pars[0].sharpened(g, d), pars[0].hardened(g, d), (g, d)):
            v = min(sign * p.evaluate(gg, dd, gradient=False).value for p in pars)
            n += len(pars)
            if best is None or v > best[0] + 1e-6 * max(1.0, abs(best[0])):
                best = (v, gg, dd)
        assert best is not None  # noqa: S101 - three candidates
        return Composed(pars[0].strategy(best[1], best[2]), (la, ld), sign * best[0], n)


@dataclass(frozen=True, eq=False)
class ResponseJob:
    """Gradient synthesis of the adversary's ``memory``-node FSS against the fixed ``defence``
    (a POMDP for the adversary) from ``logits``; returns the best of its best iterate's
    deterministic, sharpened and randomised versions, with its value (the decision maker's)."""

    PHASE: ClassVar[str] = "adversaries: double oracle"

    defence: FiniteStateStrategy
    memory: int
    logits: tuple[np.ndarray, np.ndarray]
    iterations: int
    learning_rate: float
    deadline: float | None

    def run(self, problem: Problem) -> tuple[FiniteStateStrategy, float]:
        assert problem.adversary is not None  # noqa: S101 - only asked in a game
        model = problem.model
        prod = strategy_product(model, [bind(model, self.defence)])
        par = _on_product(problem, prod, problem.adversary, self.memory,
                          Layout.of(model, problem.adversary))
        sign = -problem.sign  # the adversary works against the decision maker

        def step(la: np.ndarray, ld: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
            g, d = par.probabilities(la, ld)
            ev = par.evaluate(g, d)
            ga, gd = par.logit_gradient(ev, g, d)
            return sign * ev.value, sign * ga, sign * gd

        (la, ld), _, _ = ascend(step, *self.logits, iterations=self.iterations,
                                learning_rate=self.learning_rate, deadline=self.deadline)
        g, d = par.probabilities(la, ld)
        best: tuple[float, np.ndarray, np.ndarray] | None = None
        for gg, dd in (par.hardened(g, d), par.sharpened(g, d), (g, d)):
            v = sign * par.evaluate(gg, dd, gradient=False).value
            if best is None or round(v, 7) > round(best[0], 7):
                best = (v, gg, dd)
        assert best is not None  # noqa: S101 - three candidates
        return par.strategy(best[1], best[2]), sign * best[0]


def _on_product(problem: Problem, prod, player: int, memory: int,  # type: ignore[no-untyped-def]
                layout: Layout) -> Parametrisation:
    """``player``'s k-node FSSs on the product ``prod`` of the model with another player's
    strategy, laid out as on the model itself."""
    pm = game_views(problem.model, prod.model, prod.state_of)
    rewards = None
    if problem.rewards is not None:
        rewards = pm.reward_model(problem.query.reward).choice_rewards(pm.row_groups)  # type: ignore[union-attr]
    return Parametrisation(pm, player, memory, problem.query, problem.target[prod.state_of],
                           problem.remain[prod.state_of], coalition_of=problem.coalition_of,
                           scalar=problem.scalar, rewards=rewards, discount=problem.discount,
                           layout=layout)


def _against(problem: Problem, adversary: FiniteStateStrategy, memory: int,
             layout: Layout) -> Parametrisation:
    """The defence's k-node FSSs against one fixed adversary strategy."""
    prod = strategy_product(problem.model, [bind(problem.model, adversary)])
    return _on_product(problem, prod, problem.player, memory, layout)


def logits_of(fss: FiniteStateStrategy, layout: Layout) -> tuple[np.ndarray, np.ndarray] | None:
    """Logits whose softmax is ``fss`` (clipped to [-LOGIT, LOGIT]), or None when ``fss`` is not
    laid out like ``layout`` (its rules in the same observation and action order)."""
    k = fss.memory_size
    if fss.action.shape != (k, *layout.mask.shape):
        return None
    with np.errstate(divide="ignore"):
        la = np.clip(np.log(fss.action), -LOGIT, LOGIT)
        ld = np.clip(np.log(fss.update), -LOGIT, LOGIT)
    # where a label is never played its update is all 0: no preference among next nodes
    ld = np.where((fss.action > 0)[..., None], ld, 0.0)
    return la, ld


# -- the driver ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class OneSided:
    """What the adversary phases found. ``ranked``: (strategy, strength) of every adversary
    ranked, strongest first (the double oracle's additions included); ``kept``: the adversaries
    the defence was composed against (the M strongest, then the double oracle's additions);
    ``added``: how many of those the double oracle added; ``composed``: the composed defence
    (None when there was nothing to compose); ``responses``: per double-oracle round, the best
    response's value against the composed defence and whether it was exhaustive; ``partial``:
    the time ran out; ``all_ranked``: every enumerated strategy was ranked."""

    enumeration: Enumeration
    all_ranked: bool
    ranked: tuple[tuple[FiniteStateStrategy, float], ...]
    kept: tuple[FiniteStateStrategy, ...]
    added: int
    composed: Composed | None
    responses: tuple[tuple[float, bool], ...]
    partial: bool
    phases: dict[str, float] = field(default_factory=dict)


def one_sided(problem: Problem, executor: Executor, *, defence: FiniteStateStrategy,
              keep: int, adversary_memory: int, enumeration_limit: int, restarts: int,
              oracle_rounds: int, iterations: int, learning_rate: float, seed: int,
              deadline: float | None, milp_nodes: int = 200) -> OneSided:
    """Enumerate, rank and keep the adversary's strategies, compose the defence against them
    (starting from ``defence``, the search's) and run the double oracle (see the module
    docstring); ``deadline``: the wall-clock cap (a ``time.perf_counter()`` value, or None)."""
    assert problem.adversary is not None  # noqa: S101 - only asked in a game
    phases: dict[str, float] = {}
    sign = problem.sign
    t0 = time.perf_counter()
    progress.report("adversaries: enumeration", done=0, total=enumeration_limit,
                    unit="strategies")
    # under a cap the enumeration gets a quarter of the time left: strategies found but never
    # ranked help nobody
    enumeration = enumerate_adversaries(problem.model, problem.adversary, memory=adversary_memory,
                                        limit=enumeration_limit,
                                        deadline=None if deadline is None
                                        else t0 + 0.25 * max(deadline - t0, 0.0))
    phases["adversaries: enumeration"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    progress.report("adversaries: ranking", done=0, total=len(enumeration.strategies),
                    unit="strategies")
    strengths = _batched(executor, [RankJob(a) for a in enumeration.strategies], deadline)
    # strongest first: the lowest full-information optimum for a maximising decision maker;
    # a stable sort keeps the enumeration's order among equals
    order = sorted(range(len(strengths)), key=lambda i: sign * strengths[i])
    ranked = [(enumeration.strategies[i], strengths[i]) for i in order]
    phases["adversaries: ranking"] = time.perf_counter() - t0
    partial = len(strengths) < len(enumeration.strategies)
    all_ranked = not partial
    kept = [a for a, _ in ranked[:keep]]
    if not kept:
        return OneSided(enumeration, not partial, tuple(ranked), (), 0, None, (), partial, phases)

    layout = Layout.of(problem.model, problem.player)
    k = defence.memory_size
    rng = np.random.default_rng(seed)
    shapes = ((k, *layout.mask.shape), (k, *layout.mask.shape, k))
    starts = [logits_of(defence, layout) or (np.zeros(shapes[0]), np.zeros(shapes[1]))]
    starts += [(rng.normal(size=shapes[0]), rng.normal(size=shapes[1])) for _ in range(restarts)]
    t_compose = t_oracle = 0.0
    if expired(deadline):  # ranking used the time: nothing composed
        return OneSided(enumeration, all_ranked, tuple(ranked), tuple(kept), 0, None, (), True,
                        phases)
    t0 = time.perf_counter()
    progress.report("adversaries: composition")
    composed = _compose(executor, kept, k, defence, starts, iterations, learning_rate, deadline)
    composed = _with_milp(problem, executor, kept, composed, k, deadline, milp_nodes)
    t_compose += time.perf_counter() - t0
    responses: list[tuple[float, bool]] = []
    added = 0
    exhaustive = enumeration.exhaustive and len(enumeration.strategies) <= RESPONSE_EXHAUSTIVE \
        and not partial
    for round_no in range(oracle_rounds):
        if expired(deadline):
            partial = True
            break
        progress.report("adversaries: double oracle", done=round_no, total=oracle_rounds,
                        unit="round")
        t0 = time.perf_counter()
        response, value, complete = _best_response(problem, executor, composed.strategy,
                                                   enumeration, exhaustive, kept,
                                                   adversary_memory, iterations, learning_rate,
                                                   rng, deadline)
        t_oracle += time.perf_counter() - t0
        responses.append((value, complete))
        margin = 1e-9 * max(1.0, abs(composed.value)) if np.isfinite(composed.value) else 0.0
        if not sign * value < sign * composed.value - margin or any(response is a for a in kept):
            break  # the kept set already contains the adversary's best answer (as far as found)
        kept.append(response)
        added += 1
        if not any(response is a for a, _ in ranked):
            strength = executor.map([RankJob(response)])[0]
            ranked.append((response, strength))
            ranked.sort(key=lambda r: sign * r[1])
        t0 = time.perf_counter()
        # recompose from the current defence (never worse against the old set) and ``restarts``
        # new starts
        again = [composed.logits] + [(rng.normal(size=shapes[0]), rng.normal(size=shapes[1]))
                                     for _ in range(restarts)]
        composed = _compose(executor, kept, k, composed.strategy, again, iterations, learning_rate,
                            deadline)
        composed = _with_milp(problem, executor, kept, composed, k, deadline, milp_nodes)
        t_compose += time.perf_counter() - t0
    phases["adversaries: composition"] = t_compose
    phases["adversaries: double oracle"] = t_oracle
    return OneSided(
        enumeration,
        all_ranked,
        tuple(ranked),
        tuple(kept),
        added,
        composed,
        tuple(responses),
        partial or expired(deadline),
        phases,
    )


def _batched(executor: Executor, jobs: list, deadline: float | None,  # type: ignore[type-arg]
             size: int = 16) -> list:  # type: ignore[type-arg]
    """The jobs' results, batch by batch (``size`` jobs) until ``deadline`` (the wall-clock cap):
    a prefix of the results, at least the first batch."""
    out: list = []  # type: ignore[type-arg]
    for i in range(0, len(jobs), size):
        if i and expired(deadline):
            break
        out.extend(executor.map(jobs[i:i + size]))
    return out


def _compose(executor: Executor, adversaries: list[FiniteStateStrategy], memory: int,
             incumbent: FiniteStateStrategy, starts: list[tuple[np.ndarray, np.ndarray]],
             iterations: int, learning_rate: float, deadline: float | None) -> Composed:
    """The best composed defence over the starts, or ``incumbent`` (the defence the first start
    approximates: its logits are clipped) when none does better against ``adversaries`` — so
    composing never loses against the set (the first on a tie)."""
    jobs = [] if expired(deadline) else [
        ComposeJob(tuple(adversaries), memory, s, iterations, learning_rate, deadline)
        for s in starts]
    results: list[Composed] = executor.map(jobs)
    sign = executor.problem.sign
    values = executor.map([VersusJob(incumbent, a) for a in adversaries])
    best = Composed(incumbent, starts[0], min(values, key=lambda v: sign * v), 0)
    for r in results:
        if round(sign * r.value, 7) > round(sign * best.value, 7):
            best = r
    return best


MILP_LIMIT = 20_000
"""The MILP composition runs when the products with the kept adversaries have at most this many
states in all (a variable per product state)."""


def _with_milp(problem: Problem, executor: Executor, kept: list[FiniteStateStrategy],
               composed: Composed, memory: int, deadline: float | None,
               nodes: int) -> Composed:
    """``composed``, or the MILP's deterministic memoryless defence (:mod:`posgmc.synthesis.milp`,
    exact over those defences, within ``nodes`` branch-and-bound nodes) when the objective allows
    it and it is better against ``kept`` (by more than 1e-7); under a cap within half of the time
    left. The MILP's float optimum only proposes:
    the candidate is evaluated against every kept adversary by an exact linear solve
    (:class:`VersusJob`), and that value decides; the reported numbers are proven later by the
    sound engines."""
    if not milp.supported(problem) or expired(deadline) or problem.adversary is None:
        return composed
    if sum(strategy_product(problem.model, [bind(problem.model, a)]).model.num_states
           for a in kept) > MILP_LIMIT:
        return composed
    # at most half of what is left: the double oracle still needs time, and HiGHS on a large
    # product with end components (ranking binaries per edge) can take all of it
    now = time.perf_counter()
    found = milp.compose_milp(problem, kept, memory=memory,
                              deadline=None if deadline is None else now + 0.5 * (deadline - now),
                              bound=composed.value, nodes=nodes, incumbent=composed.value)
    if found is None:
        return composed
    sign = problem.sign
    values = _batched(executor, [VersusJob(found.strategy, a) for a in kept], deadline, size=4)
    if len(values) < len(kept):
        return composed  # not evaluated against every kept adversary within the budget
    value = min(values, key=lambda v: sign * v)
    if round(sign * value, 7) > round(sign * composed.value, 7):
        logits = logits_of(found.strategy, Layout.of(problem.model, problem.player))
        assert logits is not None  # noqa: S101 - laid out by the same Layout
        return Composed(found.strategy, logits, value, 0)
    return composed


def _best_response(problem: Problem, executor: Executor, defence: FiniteStateStrategy,
                   enumeration: Enumeration, exhaustive: bool, kept: list[FiniteStateStrategy],
                   memory: int, iterations: int, learning_rate: float, rng: np.random.Generator,
                   deadline: float | None) -> tuple[FiniteStateStrategy, float, bool]:
    """The adversary strategy that hurts ``defence`` most: over every enumerated one when
    ``exhaustive`` (batch by batch until ``deadline``), otherwise by gradient synthesis from the
    kept ones' logits (the worst first) and a random start. Returns it with the decision maker's
    value against it and whether every enumerated strategy was evaluated."""
    sign = problem.sign
    if exhaustive:
        values = _batched(executor, [VersusJob(defence, a) for a in enumeration.strategies],
                          deadline)
        i = min(range(len(values)), key=lambda j: sign * values[j])
        return enumeration.strategies[i], values[i], len(values) == len(enumeration.strategies)
    assert problem.adversary is not None  # noqa: S101 - only asked in a game
    layout = Layout.of(problem.model, problem.adversary)
    shapes = ((memory, *layout.mask.shape), (memory, *layout.mask.shape, memory))
    values = executor.map([VersusJob(defence, a) for a in kept])
    worst = min(range(len(values)), key=lambda j: sign * values[j])
    starts = [s for s in [logits_of(kept[worst], layout)] if s is not None]
    starts.append((rng.normal(size=shapes[0]), rng.normal(size=shapes[1])))
    found = executor.map([ResponseJob(defence, memory, s, iterations, learning_rate, deadline)
                          for s in starts])
    found.append((kept[worst], values[worst]))
    best: tuple[FiniteStateStrategy, float] = min(found, key=lambda r: sign * r[1])
    return best[0], best[1], False


def verified_numbers(problem: Problem, executor: Executor, defence: FiniteStateStrategy,
                     guaranteed: Bound, adversaries: tuple[FiniteStateStrategy, ...],
                     strengths: tuple[tuple[FiniteStateStrategy, float], ...], *,
                     check_options: CheckOptions, check_all: int = 4,
                     values: list[float] | None = None,
                     ) -> tuple[Bound | None, FiniteStateStrategy | None, Bound | None]:
    """(vs_fss_adversary of ``defence`` over ``adversaries``, the adversary achieving it,
    upper_bound over the ranked ``strengths``), proven by the sound engines (``check_options``).

    ``upper_bound`` is the full-information optimum against the strongest adversary (by float
    rank), checked soundly: the optimum against the strongest is at least the minimum over all,
    so its proven bounds bound what no defence exceeds. ``vs_fss_adversary``'s value and its
    bound towards the decision maker's good side come from the worst adversary's sound check
    (the worst is no better than it); its other bound needs every adversary: with at most
    ``check_all`` of them each is checked soundly, otherwise that end falls back to
    ``guaranteed``'s (the defence's value against any adversary is at least what it guarantees).
    ``values``: the defence's float values against ``adversaries`` when the caller has them.
    """
    sign = problem.sign
    vs: Bound | None = None
    worst: FiniteStateStrategy | None = None

    def proven(given: dict[str, FiniteStateStrategy], number: str) -> Bound:
        r = StrategyChecker(
            problem.model,
            given,
            coalition_of=problem.coalition_of,
            scalar=problem.scalar,
            options=check_options,
        ).check(problem.query, text=number)
        return getattr(r, number)  # type: ignore[no-any-return]

    if adversaries:
        if values is None or len(values) != len(adversaries):
            values = executor.map([VersusJob(defence, a) for a in adversaries])
        i = min(range(len(values)), key=lambda j: sign * values[j])
        worst = adversaries[i]
        vs = proven({defence.player: defence, worst.player: worst}, "vs_fss_adversary")
        if len(adversaries) <= check_all:
            others = [proven({defence.player: defence, a.player: a}, "vs_fss_adversary")
                      for j, a in enumerate(adversaries) if j != i]
            far = min([vs.lower, *(b.lower for b in others)]) if sign > 0 else \
                max([vs.upper, *(b.upper for b in others)])
            sound = vs.sound and all(b.sound for b in others)
            converged = vs.converged and all(b.converged for b in others)
        else:
            far = min(vs.lower, guaranteed.lower) if sign > 0 else max(vs.upper, guaranteed.upper)
            sound = vs.sound and guaranteed.sound
            converged = vs.converged and guaranteed.converged
        vs = (
            Bound(vs.value, far, vs.upper, sound, converged)
            if sign > 0
            else Bound(vs.value, vs.lower, far, sound, converged)
        )
    ub: Bound | None = None
    if strengths:
        strongest = strengths[0][0]  # ranked strongest first
        ub = proven({strongest.player: strongest}, "upper_bound")
    return vs, worst, ub
