"""The decision maker's randomised k-FSS as a parameter vector, and the exact value and gradient
of what it guarantees against the omniscient adversary's best response.

Parameters: logits ``A[n, z, a]`` (softmax over the labels observation z offers) for the action
map γ, and logits ``D[n, z, a, n']`` (softmax over the k nodes) for the memory update δ, for
every memory node n and every observation z of the decision maker. Since softmax probabilities
are positive, the product's reachable structure does not depend on θ.

Evaluation at θ (Danskin's theorem for ``min over adversaries``): build the product with the FSS
(:mod:`posgmc.strategies.product`), let the engines solve the adversary's optimum on it and fix
the adversary's optimal choices, then solve the induced chain exactly (one sparse LU) and its
adjoint: with ``x = (I - P_UU)^{-1} b_U`` the values of the undecided states U and
``y^T (I - P_UU) = e_init``, the derivative of the initial value along a change of the defence's
rows is ``y^T (dP x + db)``. A defence row of product state (s, n) under observation z is
``Σ_a γ(n,z,a) Σ_n' δ(n,z,a,n') P(s,a,·)`` over (s', n'), so with ``W[c, n'] = Σ_s' P(c,s')
x(s',n')``

    ∂/∂γ(n,z,a) = Σ_(s,n) y · Σ_n' δ(n,z,a,n') W[c(s,a), n'],  ∂/∂δ(n,z,a,n') = Σ_(s,n) y · γ · W[c,
    n'],

and the softmax chain rule gives the logits' gradient. This is the subgradient of the max-min at
θ (exact where the adversary's best response is unique). Two objectives: reachability
probabilities (``P[a U b]``, ``F``) and the discounted cost until a target (``R[Fdiscount=g b]``,
the seed paper's cost form: ``x = r + g P x`` off the target, and the action's own cost joins
``∂/∂γ``). The numbers reported to users come from the sound engines
(:mod:`posgmc.strategies.verify`), never from this float evaluation.

The decision maker must be the only player with memory: ``K = k``, product state (s, n).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph
from scipy.sparse.linalg import splu

from posgmc.checking.property_checker import (
    CheckOptions,
    CoalitionResolver,
    PropertyChecker,
    ScalarEvaluator,
)
from posgmc.engines import kernels
from posgmc.engines.graph import (
    Structure,
    almost_sure_reach,
    positive_reach,
    structure_of,
)
from posgmc.engines.options import Method, SolverOptions
from posgmc.engines.row_slots import RowSlots
from posgmc.engines.support_cache import SupportCache, digest
from posgmc.engines.system import HAVE_KERNELS, accumulate_rows
from posgmc.model.explicit import ExplicitModel
from posgmc.strategies.binding import bind, player_view
from posgmc.strategies.fss import FiniteStateStrategy
from posgmc.strategies.product import StrategyProduct, strategy_product
from posgmc.syntax.ast import ProbQuery, RewardQuery
from posgmc.synthesis.ordered_evaluation import OrderedPlan
from posgmc.synthesis.product_template import ProductTemplate, support_key

__all__ = ["Parametrisation", "Evaluation", "Layout", "game_views", "ITERATIVE_STATES"]

ITERATIVE_STATES = 50_000
"""Products with at least this many states are evaluated by warm-started value iteration
(:meth:`Parametrisation._evaluate_iterative`) instead of sparse LU factorisations, whose fill-in
makes each solve cost seconds at 10^5 states."""

TEMPLATES = 4
"""Product templates kept per parametrisation (the supports seen last)."""

ITERATIVE_SWEEPS = 20_000
"""At most this many sweeps per iterative solve."""

ITERATIVE_TOLERANCE = 1e-9
"""An iterative solve stops when a sweep changes no value by more than this (relative)."""


_WarmStart = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]
"""(state_of, memory_of, undecided states, values, adjoint or None) of the last iterative
evaluation."""


def game_views(model: ExplicitModel, product: ExplicitModel, state_of: np.ndarray) -> ExplicitModel:
    """``product`` (of ``model`` with strategies or an automaton; ``state_of``: int64[P], the
    model state of each product state) with every player viewing it as it views ``model``: a
    fully observing player gets an explicit observation of the model state, where it would
    otherwise see the product state (memory nodes or automaton state included). So a strategy
    laid out on ``model`` (:class:`Layout`) means the same on the product."""
    import dataclasses

    from posgmc.model.explicit import Observation

    observations = [
        dataclasses.replace(o, state_ids=o.state_ids[state_of]) for o in model.observations
    ]
    for p in range(max(len(model.player_names), 1)):
        if model.observation_of(p) is None:
            view = player_view(model, p)
            observations.append(Observation(p, view.state_obs[state_of].astype(np.int32),
                                            view.observables, view.obs_values))
    return dataclasses.replace(product, observations=tuple(observations))


@dataclass(frozen=True, eq=False)
class Layout:
    """Which parameters a player's FSS has: ``used_obs`` int64[Zu], the observation ids of the
    player's states; ``used_actions`` int64[Au], the labels offered there; ``mask`` bool[Zu, Au],
    the labels each observation offers. Taken from the whole model, so that one parameter vector
    means the same strategy on every product of the model with an adversary's strategy (the
    product keeps only the states reachable under that adversary)."""

    used_obs: np.ndarray
    used_actions: np.ndarray
    mask: np.ndarray

    @staticmethod
    def of(model: ExplicitModel, player: int) -> Layout:
        view = player_view(model, player)
        owned = (
            (model.state_players == player)
            if model.player_names
            else np.ones(model.num_states, bool)
        )
        rows = np.flatnonzero(owned[model.choice_states])
        offered = np.zeros((view.num_observations, len(model.action_names)), dtype=bool)
        offered[view.state_obs[model.choice_states[rows]], model.choice_actions[rows]] = True
        used_obs = np.flatnonzero(offered.any(axis=1))
        used_actions = np.flatnonzero(offered.any(axis=0))
        return Layout(used_obs, used_actions, offered[np.ix_(used_obs, used_actions)])


@dataclass(frozen=True)
class Evaluation:
    """``value`` at the initial state (float), ``grad_action``/``grad_update`` with the shapes of
    the logits."""

    value: float
    grad_action: np.ndarray
    grad_update: np.ndarray


class Parametrisation:
    """The defence's FSSs of ``memory`` nodes for player ``player`` of ``model``.

    Args:
        model: the game (or pomdp).
        player: the decision maker's index.
        memory: k >= 1.
        query: the property (a ``P`` query of ``[a U b]``/``F b``, unbounded).
        target, remain: bool[S] of the model (where ``b`` and ``a`` hold).
        coalition_of, scalar: as for the checker (the adversary's best response).
    """

    def __init__(
        self,
        model: ExplicitModel,
        player: int,
        memory: int,
        query: ProbQuery | RewardQuery,
        target: np.ndarray,
        remain: np.ndarray,
        *,
        coalition_of: CoalitionResolver,
        scalar: ScalarEvaluator,
        rewards: np.ndarray | None = None,
        discount: float = 1.0,
        layout: Layout | None = None,
    ) -> None:
        self.model, self.player, self.k, self.query = model, player, memory, query
        self.rewards, self.discount = rewards, discount  # discounted cost: reward per choice
        self.coalition_of, self.scalar = coalition_of, scalar
        self.target, self.remain = target, remain
        self.view = player_view(model, player)
        owned = (
            (model.state_players == player)
            if model.player_names
            else np.ones(model.num_states, bool)
        )
        self.owned = owned
        Z, A = self.view.num_observations, len(model.action_names)
        if layout is None:
            layout = Layout.of(model, player)
        self.layout = layout
        self.used_obs, self.used_actions, self.mask = (
            layout.used_obs,
            layout.used_actions,
            layout.mask,
        )
        self.obs_index = np.full(Z, -1, dtype=np.int64)
        self.obs_index[self.used_obs] = np.arange(self.used_obs.size)
        self.act_index = np.full(A, -1, dtype=np.int64)
        self.act_index[self.used_actions] = np.arange(self.used_actions.size)
        self.maximize = query.direction is None or query.direction.name == "MAX"
        # the products of the supports seen last (a search's candidates share one support)
        self._templates: dict[bytes, ProductTemplate] = {}
        # (state_of, memory_of, best response) of the last evaluation: the next one's warm start
        self._last_response: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        # (state_of, memory_of, undecided states, values, adjoint) of the last iterative
        # evaluation: the next one's warm start on the same product structure
        self._warm: _WarmStart | None = None
        # the component order of the last product structure evaluated by the compiled kernel
        self._plan: OrderedPlan | None = None

    def forget_response(self) -> None:
        """Drop the warm start: the next evaluation solves the adversary's MDP from scratch."""
        self._last_response = None
        self._warm = None

    # -- θ <-> strategies --------------------------------------------------------------------------

    @property
    def shapes(self) -> tuple[tuple[int, ...], tuple[int, ...]]:
        Zu, Au = self.mask.shape
        return (self.k, Zu, Au), (self.k, Zu, Au, self.k)

    def probabilities(
        self, logits_a: np.ndarray, logits_d: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Softmax of the logits: γ[k, Zu, Au] (0 where a label is not offered), δ[k, Zu, Au, k]."""
        a = np.where(self.mask[None], logits_a, -np.inf)
        a = np.exp(a - a.max(axis=2, keepdims=True))
        gamma = a / a.sum(axis=2, keepdims=True)
        d = np.exp(logits_d - logits_d.max(axis=3, keepdims=True))
        delta = d / d.sum(axis=3, keepdims=True)
        return gamma, delta

    def strategy(self, gamma: np.ndarray, delta: np.ndarray) -> FiniteStateStrategy:
        """The FSS with these probabilities (rules for every observation of the player)."""
        return FiniteStateStrategy.from_arrays(
            player=self.view.name,
            observables=self.view.observables,
            observation_values=self.view.obs_values[self.used_obs],
            actions=tuple(self.model.action_names[a] for a in self.used_actions),
            action=gamma,
            update=delta * (gamma[..., None] > 0),
        )

    def hardened(self, gamma: np.ndarray, delta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The deterministic FSS of the most likely action and next node of every rule."""
        g = np.zeros_like(gamma)
        np.put_along_axis(g, gamma.argmax(axis=2)[..., None], 1.0, axis=2)
        d = np.zeros_like(delta)
        np.put_along_axis(d, delta.argmax(axis=3)[..., None], 1.0, axis=3)
        return g, d

    def sharpened(self, gamma: np.ndarray, delta: np.ndarray, *, floor: float = 0.02
                  ) -> tuple[np.ndarray, np.ndarray]:
        """The FSS without its unlikely choices: probabilities below ``floor`` set to 0 and each
        rule renormalised. The softmax never gives exactly 0, and a loop the strategy leaves with
        probability 1e-4 per turn makes sound interval iteration crawl (10^5 iterations); the
        sharpened strategy is usually as good, and is verified in a few."""

        def cut(p: np.ndarray, axis: int) -> np.ndarray:
            kept = np.where(p >= floor, p, 0.0)
            total = kept.sum(axis=axis, keepdims=True)
            out: np.ndarray = np.divide(kept, total, out=p.copy(), where=total > 0)
            return out

        return cut(gamma, 2), cut(delta, 3)

    # -- value and gradient --------------------------------------------------------------------

    def evaluate(
        self, gamma: np.ndarray, delta: np.ndarray, *, gradient: bool = True
    ) -> Evaluation:
        """The initial value against the adversary's best response, and its gradient with respect
        to γ and δ (not yet through the softmax: see :meth:`logit_gradient`)."""
        prod = self._product(gamma, delta)
        pm = prod.model
        if pm.num_states >= ITERATIVE_STATES and self._iterative_applies():
            return self._evaluate_iterative(prod, gamma, delta, gradient=gradient)
        # policy iteration: exact best responses, and no slow convergence near deterministic loops;
        # warm-started from the previous evaluation's best response when the product is the same
        # (successive steps of a search change the defence a little: one or two linear solves)
        initial = None
        last = self._last_response
        if last is not None and np.array_equal(last[0], prod.state_of) and np.array_equal(
            last[1], prod.memory_of
        ):
            initial = last[2]
        strategy = None
        if pm.transitions.shape[0] > pm.num_states:  # someone still chooses: the best response
            solver = SolverOptions(method=Method.POLICY, initial_strategy=initial,
                                   prove=False)
            checker = PropertyChecker(pm, coalition_of=self.coalition_of, scalar=self.scalar,
                                      options=CheckOptions(solver=solver, keep_strategy=True))
            q = checker.query(self.query)
            strategy = q.engine.strategy if q.engine is not None else None
            if strategy is not None:
                self._last_response = (prod.state_of, prod.memory_of, strategy)
        rows = pm.row_groups[:-1].copy()
        if strategy is not None:
            rows = np.where(strategy >= 0, strategy, rows)
        P = pm.transitions[rows].tocsr()  # the induced chain
        tgt = self.target[prod.state_of]
        rem = self.remain[prod.state_of]
        S = pm.num_states
        chain = sp.csr_matrix(P)
        init = int(prod.initial_map[0])
        zero_a, zero_d = np.zeros(self.shapes[0]), np.zeros(self.shapes[1])
        g_disc = self.discount
        if self.rewards is None:  # reachability: x = P x on U, 1 on the target, 0 elsewhere
            unknown = chain_reach(chain, tgt, rem) & ~tgt
            x = tgt.astype(np.float64)
        elif g_disc < 1.0:  # discounted cost until the target: x = r + g P x off the target
            unknown = ~tgt
            x = np.zeros(S)
        else:  # expected reward until the target (PRISM's F): infinite unless reached surely
            sure, _ = almost_sure_reach(structure_of_chain(chain), tgt, np.ones(S, dtype=bool),
                                        existential=np.ones(S, dtype=bool))
            unknown = sure & ~tgt
            x = np.where(sure, 0.0, np.inf)
        U = np.flatnonzero(unknown)
        if U.size == 0 or not np.isfinite(x[init]):
            return Evaluation(float(x[init]), zero_a, zero_d)
        rows_u = chain[U]  # selected once: each selection of a small matrix costs scipy ~0.1 ms
        PUU = rows_u[:, U].tocsc()
        if self.rewards is None:
            b = np.asarray(rows_u[:, np.flatnonzero(tgt)].sum(axis=1)).ravel()
        else:
            prod_rewards = pm.reward_model(self.query.reward).choice_rewards(pm.row_groups)  # type: ignore[union-attr]
            b = prod_rewards[rows][U]
        lu = splu((sp.identity(U.size, format="csc") - g_disc * PUU).tocsc())
        x[U] = lu.solve(b)
        value = float(x[init])
        if not gradient or not unknown[init]:
            return Evaluation(value, zero_a, zero_d)
        e = np.zeros(U.size)
        e[np.searchsorted(U, init)] = 1.0
        y_u = lu.solve(e, trans="T")
        y = np.zeros(S)
        y[U] = y_u
        return self._gradient(prod, x, y, gamma, delta, value)

    def _product(self, gamma: np.ndarray, delta: np.ndarray) -> StrategyProduct:
        """The product with the FSS γ, δ: refilled from the template of its support when there is
        one (probability objectives, :mod:`~posgmc.synthesis.product_template`), else built (and
        made the template of its support)."""
        m = self.model
        refillable = self.rewards is None and bool(
            np.all(np.isfinite(gamma)) and np.all(np.isfinite(delta)))
        key = support_key(gamma, delta) if refillable else b""
        found = self._templates.get(key) if refillable else None
        if found is not None:
            return found.refill(gamma, delta)
        prod = strategy_product(m, [bind(m, self.strategy(gamma, delta))])
        if refillable:
            template = ProductTemplate.of(
                m, prod, key, owned=self.owned, obs_index=self.obs_index,
                act_index=self.act_index, state_obs=self.view.state_obs,
                shape=(self.k, *self.mask.shape))
            if template is not None:
                if len(self._templates) >= TEMPLATES:
                    del self._templates[next(iter(self._templates))]  # the oldest
                self._templates[key] = template
        return prod

    def _gradient(self, prod, x: np.ndarray, y: np.ndarray, gamma: np.ndarray,  # type: ignore[no-untyped-def]
                  delta: np.ndarray, value: float) -> Evaluation:
        """The gradient of the initial value from the product's values ``x`` and adjoint ``y``
        (float64[P] each; y zero outside the undecided states)."""
        m = self.model
        g_disc = self.discount
        # values on the (state, node) grid, for W[c, n'] = Σ_s' P(c, s') x(s', n')
        grid = np.zeros((m.num_states, self.k))
        # an infinite value (a reward never ending) enters the gradient as a large finite one, so
        # that moving towards it is strongly rewarded (Rmax) or punished (Rmin) but stays a number
        finite = np.isfinite(x)
        big = 10.0 * (float(np.abs(x[finite]).max(initial=0.0)) + 1.0)
        grid[prod.state_of, prod.memory_of[:, 0]] = np.where(finite, x, big)
        W = g_disc * np.asarray(m.transitions @ grid)  # [C, k]
        # every defence product state with weight y: its choices c, node n, observation z
        defend = np.flatnonzero(self.owned[prod.state_of] & (y != 0))
        s = prod.state_of[defend]
        n = prod.memory_of[defend, 0]
        counts = np.diff(m.row_groups)[s]
        c = np.repeat(m.row_groups[s], counts) + _ranges(counts)
        q_of_c = np.repeat(np.arange(defend.size), counts)
        zi = self.obs_index[self.view.state_obs[s]][q_of_c]
        ai = self.act_index[m.choice_actions[c]]
        ni = n[q_of_c]
        yc = y[defend][q_of_c]
        Wc = W[c]  # [E, k]
        d = delta[ni, zi, ai]  # [E, k]
        own = np.sum(d * Wc, axis=1)
        if self.rewards is not None:
            own = own + self.rewards[c]  # the action's own cost
        # sums per parameter by bincount (in entry order, as np.add.at adds, at a fraction of
        # its cost)
        shape_a = self.shapes[0]
        size_a = int(np.prod(shape_a))
        flat = np.ravel_multi_index((ni, zi, ai), shape_a)
        grad_a = np.bincount(flat, weights=yc * own, minlength=size_a).reshape(shape_a)
        k = self.k
        weights = ((yc * gamma[ni, zi, ai])[:, None] * Wc).ravel()
        grad_d = np.bincount((flat[:, None] * k + np.arange(k)).ravel(), weights=weights,
                             minlength=size_a * k).reshape(self.shapes[1])
        return Evaluation(value, grad_a, grad_d)

    # -- large products: warm-started value iteration ---------------------------------------------

    def _iterative_applies(self) -> bool:
        """Whether value iteration from any start converges to the value: the discounted cost (a
        contraction), and reachability when nobody maximises it against the defence (no
        adversary, or an adversary minimising once its probability-0 states are fixed; an
        adversary maximising a probability could stay in an end component at a warm start's
        value, and the undiscounted expected reward has infinite values)."""
        if self.rewards is not None:
            return self.discount < 1.0
        return self.maximize or len(self.model.player_names) <= 1

    def _evaluate_iterative(self, prod, gamma: np.ndarray, delta: np.ndarray, *,  # type: ignore[no-untyped-def]
                            gradient: bool) -> Evaluation:
        """:meth:`evaluate` on a large product: the adversary's best response and the chain's
        values by value iteration, the adjoint by the transposed iteration, each warm-started
        from the previous evaluation on the same product structure (a sparse LU of a product of
        10^5 states fills in to ~3·10^7 entries: seconds per solve, four per best response).
        Iterations stop when a sweep changes nothing by more than ``ITERATIVE_TOLERANCE``
        (relative to the largest value), at most ``ITERATIVE_SWEEPS`` sweeps: an estimate for
        the search, which never reports it."""
        pm = prod.model
        S = pm.num_states
        T = pm.transitions.tocsr()
        rg = pm.row_groups
        g_disc = self.discount
        tgt = self.target[prod.state_of]
        choosing = np.diff(rg) > 1
        warm = self._warm
        same = warm is not None and _equal(warm[0], prod.state_of) and _equal(
            warm[1], prod.memory_of)
        if same and warm is not None:
            unknown = warm[2]
        elif self.rewards is None:
            # the adversary (universal here) can keep the probability at 0 from the others
            rem = self.remain[prod.state_of]
            unknown = positive_reach(structure_of(pm), tgt, rem, existential=~choosing) & ~tgt
        else:
            unknown = ~tgt
        if self.rewards is None:
            x = tgt.astype(np.float64)
            offset = None
        else:
            x = np.zeros(S)
            offset = pm.reward_model(self.query.reward).choice_rewards(rg)  # type: ignore[union-attr]
        if same and warm is not None:
            x[unknown] = warm[3][unknown]
        if kernels.enabled():
            return self._evaluate_ordered(prod, T, unknown, x, offset, gamma, delta,
                                          warm if same else None, gradient=gradient)
        reduce = np.minimum if self.maximize else np.maximum  # the adversary's side
        any_choice = bool(T.shape[0] > S)
        # only the undecided states U are iterated (the others keep their fixed values). One
        # sweep: the values of U's rows into a buffer (scipy's kernel, no operator dispatch), the
        # rows laid out by slot (:mod:`posgmc.engines.row_slots`: no reduceat over 10^5 groups)
        # The columns are renumbered U first, so that the iterate is one vector whose head is U's
        # values: no gather or scatter of U per sweep (each row keeps its stored order, so its
        # sum is the same)
        U = np.flatnonzero(unknown)
        nU = U.size
        columns = np.concatenate([U, np.flatnonzero(~unknown)])
        position = np.empty(S, dtype=T.indices.dtype)
        position[columns] = np.arange(S, dtype=position.dtype)
        by_slot = RowSlots.of(rg[U], np.diff(rg)[U])
        order = by_slot.order
        T_slots = T[order]
        T_slots = sp.csr_matrix((T_slots.data, position[T_slots.indices], T_slots.indptr),
                                shape=T_slots.shape)
        offset_slots = offset[order] if offset is not None else None
        row_buf = np.empty(order.size)
        best_buf, diff = np.empty(nU), np.empty(nU)  # reused: no allocation per sweep

        def sweep(values: np.ndarray) -> np.ndarray:
            """The adversary's optimum in every state of U, in ``best_buf`` (the rows' values
            stay in ``row_buf``)."""
            _row_values(T_slots, values, row_buf)
            if g_disc != 1.0:
                np.multiply(row_buf, g_disc, out=row_buf)
            if offset_slots is not None:
                np.add(row_buf, offset_slots, out=row_buf)
            return by_slot.best(row_buf, reduce, out=best_buf)

        # the largest value outside U never changes: the stopping rule's scale is kept apart
        fixed_scale = max(1.0, float(np.abs(x[~unknown]).max(initial=0.0)))
        xp = x[columns]  # the iterate, U first
        head = xp[:nU]
        for _ in range(ITERATIVE_SWEEPS):
            new = sweep(xp)
            np.subtract(new, head, out=diff)
            change = float(np.abs(diff, out=diff).max(initial=0.0))
            head[:] = new
            np.abs(new, out=diff)
            scale = max(fixed_scale, float(diff.max(initial=0.0)))
            if change <= ITERATIVE_TOLERANCE * scale:
                break
        x[U] = head
        init = int(prod.initial_map[0])
        value = float(x[init])
        y_warm = warm[4] if same and warm is not None and warm[4] is not None else None
        if not gradient or not unknown[init]:
            self._warm = (prod.state_of, prod.memory_of, unknown, x, y_warm)
            return Evaluation(value, np.zeros(self.shapes[0]), np.zeros(self.shapes[1]))
        # the best response in U: the first row attaining the adversary's optimum (outside U the
        # adjoint is 0, so no row there matters)
        pick = np.zeros(U.size, dtype=np.int64)
        if any_choice:
            pick = by_slot.first_attaining(row_buf, sweep(xp))
        # the adjoint on U: y = g P_UU^T y + e_init (y = 0 outside U)
        chain_t = T[rg[U] + pick][:, U].T.tocsr()
        at = int(np.searchsorted(U, init))
        if y_warm is not None:
            y_u = y_warm[U]
        else:
            y_u = np.zeros(nU)
            y_u[at] = 1.0
        # two buffers swapped per sweep, no allocation (y >= 0: P and e_init are)
        new, diff = np.empty(nU), np.empty(nU)
        for _ in range(ITERATIVE_SWEEPS):
            _row_values(chain_t, y_u, new)
            if g_disc != 1.0:
                np.multiply(new, g_disc, out=new)
            new[at] += 1.0
            np.subtract(new, y_u, out=diff)
            change = float(np.abs(diff, out=diff).max(initial=0.0))
            y_u, new = new, y_u
            if change <= ITERATIVE_TOLERANCE * max(1.0, float(y_u.max(initial=0.0))):
                break
        y = np.zeros(S)
        y[U] = y_u
        self._warm = (prod.state_of, prod.memory_of, unknown, x, y)
        return self._gradient(prod, x, y, gamma, delta, value)

    def _evaluate_ordered(self, prod, T: sp.csr_matrix, unknown: np.ndarray,  # type: ignore[no-untyped-def]
                          x: np.ndarray, offset: np.ndarray | None, gamma: np.ndarray,
                          delta: np.ndarray, warm: _WarmStart | None, *,
                          gradient: bool) -> Evaluation:
        """:meth:`_evaluate_iterative` by the compiled Gauss-Seidel kernel in the order of the
        product's strongly connected components (:mod:`~posgmc.synthesis.ordered_evaluation`),
        its plan built once per product structure; ``x`` holds the fixed values outside the
        undecided states and the start on them."""
        plan = self._plan
        if plan is None or not plan.fits(T, unknown):
            plan = OrderedPlan.of(T, prod.model.row_groups, unknown)
            self._plan = plan
        U = plan.U
        g_disc = self.discount
        fixed_scale = max(1.0, float(np.abs(x[~unknown]).max(initial=0.0)))
        plan.values(T, x, offset, discount=g_disc, minimize=self.maximize,
                    tol=ITERATIVE_TOLERANCE, scale=fixed_scale, max_sweeps=ITERATIVE_SWEEPS)
        init = int(prod.initial_map[0])
        value = float(x[init])
        y_warm = warm[4] if warm is not None else None
        if not gradient or not unknown[init]:
            self._warm = (prod.state_of, prod.memory_of, unknown, x, y_warm)
            return Evaluation(value, np.zeros(self.shapes[0]), np.zeros(self.shapes[1]))
        pick = plan.best_rows(T, x, offset, discount=g_disc, minimize=self.maximize)
        rg = prod.model.row_groups
        chain_t = T[rg[U] + pick][:, U].T.tocsr()
        at = int(np.searchsorted(U, init))
        if y_warm is not None:
            y_u = y_warm[U].copy()
        else:
            y_u = np.zeros(U.size)
        plan.adjoint(chain_t, y_u, at, discount=g_disc, tol=ITERATIVE_TOLERANCE,
                     max_sweeps=ITERATIVE_SWEEPS)
        y = np.zeros(prod.model.num_states)
        y[U] = y_u
        self._warm = (prod.state_of, prod.memory_of, unknown, x, y)
        return self._gradient(prod, x, y, gamma, delta, value)

    def logit_gradient(
        self, ev: Evaluation, gamma: np.ndarray, delta: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The gradient with respect to the logits (softmax Jacobian)."""
        ga = gamma * (ev.grad_action - np.sum(gamma * ev.grad_action, axis=2, keepdims=True))
        gd = delta * (ev.grad_update - np.sum(delta * ev.grad_update, axis=3, keepdims=True))
        return ga * self.mask[None], gd


def _row_values(A: sp.csr_matrix, x: np.ndarray, out: np.ndarray) -> None:
    """``out = A @ x`` in place (scipy's kernel where available: the solves here are thousands of
    sweeps of one matrix, and the operator's dispatch and allocation cost as much as the
    product)."""
    out.fill(0.0)
    if HAVE_KERNELS:
        accumulate_rows(A, 0, A.shape[0], x, out)
    else:  # pragma: no cover - depends on the scipy build
        out += A @ x


def _equal(a: np.ndarray, b: np.ndarray) -> bool:
    """The same array (a refilled product shares its template's) or equal contents."""
    return a is b or bool(np.array_equal(a, b))


def _ranges(counts: np.ndarray) -> np.ndarray:
    """0..c-1 for each count c, concatenated."""
    total = int(counts.sum())
    starts = np.repeat(np.cumsum(counts) - counts, counts)
    out: np.ndarray = np.arange(total) - starts
    return out


def chain_reach(chain: sp.csr_matrix, target: np.ndarray, remain: np.ndarray) -> np.ndarray:
    """bool[S]: the states of a Markov chain (square matrix, one row per state) with a path of
    positive probability to ``target`` through ``remain`` (the target included) — the engines'
    ``positive_reach`` on the chain, as one breadth-first search (scipy's, compiled) backwards
    from a virtual root before every target state, with no per-layer Python step. Remembered per
    support of the chain (:data:`_REACHED`): the candidates of a search induce the same few
    chains' patterns with other probabilities."""
    key = digest(chain.indptr, chain.indices, chain.data > 0, int(chain.shape[1]),
                 np.asarray(target, dtype=bool), np.asarray(remain, dtype=bool))
    found = _REACHED.get(key)
    if found is None:
        found = _chain_search(chain, target, remain)
        found.flags.writeable = False
        _REACHED.put(key, found)
    return found.copy()


_REACHED: SupportCache[np.ndarray] = SupportCache(lambda a: int(a.nbytes))
"""The answers of :func:`chain_reach` for recent chains (a cache, not configuration)."""


def _chain_search(chain: sp.csr_matrix, target: np.ndarray, remain: np.ndarray) -> np.ndarray:
    """:func:`chain_reach` by the breadth-first search."""
    S = chain.shape[0]
    coo = sp.coo_matrix(chain)
    edge = (coo.data > 0) & remain[coo.row] & ~target[coo.row]
    goal = np.flatnonzero(target)
    src = np.concatenate([coo.col[edge].astype(np.int64), np.full(goal.size, S)])
    dst = np.concatenate([coo.row[edge].astype(np.int64), goal])
    graph = sp.csr_matrix((np.ones(src.size, dtype=np.int8), (src, dst)), shape=(S + 1, S + 1))
    order = csgraph.breadth_first_order(graph, S, directed=True, return_predecessors=False)
    found = np.zeros(S + 1, dtype=bool)
    found[order] = True
    out: np.ndarray = found[:S] | target
    return out


def structure_of_chain(chain: sp.csr_matrix) -> Structure:
    """The graph structure of a Markov chain given as a square matrix (one row per state): its
    canonical csr form (duplicates summed, zeros dropped, indices sorted, as a model holds it),
    without building and validating a model around it (one per evaluated candidate)."""
    T = sp.csr_matrix(chain, dtype=np.float64, copy=True)
    T.sum_duplicates()
    T.eliminate_zeros()
    T.sort_indices()
    return Structure.build(T, np.arange(T.shape[0] + 1, dtype=np.int64))
