"""The product of a game with finite-state strategies: what remains to be decided, as a model.

Given some players' finite-state strategies, the product's states are pairs (s, m) of a model
state and the joint memory m of those strategies; only the reachable part is kept. A state owned
by a player with a strategy gets one row, the strategy's mixture: from (s, m) with n = the
player's node and z = its observation of s,

    P((s, m) -> (s', m[n := n'])) = Σ_a γ(n, z)(a) · δ(n, z, a)(n') · P(s, a, s'),

and the expected action reward Σ_a γ(n, z)(a) · r(s, a) (turn-based: a player consults and
updates its memory only in its own states). A state owned by a player without a strategy keeps
all its choices, with every memory unchanged: that player sees the whole product state (s, m),
i.e. it is omniscient, knowing the others' memory too — PAYNT's POSMG semantics. So

* fixing the decision maker gives an MDP for the adversary (or a game, with more players): its
  optimum is what the decision maker's strategy guarantees against every adversary;
* fixing every player gives a Markov chain: the exact value of the strategy profile;
* fixing the adversary gives an MDP in which the decision maker sees everything: its optimum
  bounds what any decision-maker strategy can reach against that adversary.

The construction is whole-array work: the model is laid out K times (K = the product of the
memory sizes), the strategies' mixtures are computed for every (choice, memory) pair at once,
and the reachable part is found by one breadth-first search (scipy.sparse.csgraph).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from posgmc.model.explicit import ExplicitModel, Observation, RewardModel, make_model
from posgmc.resources import check_allocation
from posgmc.strategies.binding import BoundStrategy, _state_text
from posgmc.strategies.fss import FiniteStateStrategy, StrategyError
from posgmc.syntax.ast import ModelType

__all__ = ["StrategyProduct", "strategy_product"]


@dataclass(frozen=True, eq=False)
class StrategyProduct:
    """``model``: the product (only reachable states); ``state_of``: int64[P], the model state of
    each product state; ``memory_of``: int64[P, len(strategies)], each strategy's memory node;
    ``initial_map``: int64[I], the product state of each of the model's initial states."""

    model: ExplicitModel
    state_of: np.ndarray
    memory_of: np.ndarray
    strategies: tuple[BoundStrategy, ...]
    initial_map: np.ndarray


def _product_type(model: ExplicitModel, all_fixed: bool) -> ModelType:
    if all_fixed:
        return ModelType.DTMC
    return {ModelType.POSG: ModelType.SMG, ModelType.POMDP: ModelType.MDP}.get(
        model.model_type, model.model_type
    )


def strategy_product(model: ExplicitModel, strategies: Sequence[BoundStrategy]) -> StrategyProduct:
    """The reachable product of ``model`` with the given players' strategies.

    Args:
        model: the compiled model (any type; observations are the strategies' business).
        strategies: at most one bound strategy per player.

    Returns:
        The product; its players keep their indices and names, its observations are the model's
        (the players observe model states only).

    Raises:
        StrategyError: two strategies for one player, or a (memory, observation) pair reached
            under the strategies for which a strategy has no rule.
    """
    strategies = tuple(strategies)
    players = [b.player for b in strategies]
    if len(set(players)) != len(players):
        raise StrategyError("two strategies for one player")
    layout = _layout(model, strategies)
    rows = _Rows.empty(layout.num_rows)
    _free_choices(model, layout, rows)
    _strategy_choices(model, strategies, layout, rows)
    full = rows.matrix(layout)
    reach = _reachable_part(model, strategies, layout, rows, full)
    return _assemble(model, strategies, layout, rows, full, reach)


@dataclass(frozen=True, eq=False)
class _Layout:
    """The model laid out K times, K = the product of the strategies' memory sizes: product state
    ``s * K + m``. ``ks``/``strides``: each strategy's memory size and its place in m;
    ``fixed_by``: int64[S], the strategy owning each state (-1: none); ``counts``: int64[S * K],
    each product state's rows (one for a fixed state, the model's choices otherwise);
    ``row_start``: int64[S * K], its first row; ``memories``: int64[K] = 0..K-1; ``nodes``: per
    strategy, int64[k_i] the memory nodes it can enter (sorted): only those are laid out, so its
    i-th is the memory node of compact number i (a ``memory_size`` far above the nodes its rules
    use costs nothing)."""

    num_states: int
    ks: list[int]
    strides: list[int]
    fixed_by: np.ndarray
    counts: np.ndarray
    row_start: np.ndarray
    num_rows: int
    memories: np.ndarray
    nodes: list[np.ndarray]

    @property
    def K(self) -> int:  # noqa: N802 - the joint memory size, as in the module docstring
        return int(self.memories.size)


def _layout(model: ExplicitModel, strategies: tuple[BoundStrategy, ...]) -> _Layout:
    """The product's layout: which states the strategies fix and the rows of every product state."""
    S, rg = model.num_states, model.row_groups
    nodes = [_entered_nodes(b.fss) for b in strategies]
    ks = [int(n.size) for n in nodes]
    K = math.prod(ks)
    strides = [math.prod(ks[i + 1:]) for i in range(len(ks))]
    # the product is laid out over all S·K pairs before the reachable part is cut out
    check_allocation(
        (48.0 * S + 24.0 * model.transitions.nnz) * K,
        f"the product of the model ({S:,} states) with the strategies' memory "
        f"({' x '.join(map(str, ks))} = {K:,} joint memory nodes)",
        hint="use strategies with fewer memory nodes, or a smaller model",
    )
    num_choices = np.diff(rg)
    fixed_by = np.full(S, -1, dtype=np.int64)
    for i, b in enumerate(strategies):
        fixed_by[b.owned] = i
    rows_per_state = np.where(fixed_by >= 0, 1, num_choices)
    counts = np.repeat(rows_per_state, K)  # product state s*K + m
    prod_rg = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    return _Layout(S, ks, strides, fixed_by, counts, prod_rg[:-1], int(prod_rg[-1]),
                   np.arange(K, dtype=np.int64), nodes)


def _entered_nodes(fss: FiniteStateStrategy) -> np.ndarray:
    """int64[k']: the memory nodes the strategy can enter, sorted: its initial node and every
    node an update of an entered node's rules leads to (a search over the nodes its rules name,
    never over all ``memory_size`` nodes)."""
    named = np.unique(np.concatenate([[fss.initial_memory], fss.rule_memory, fss.update_node]))
    entry_rule = np.repeat(np.arange(fss.num_rules), np.diff(fss.choice_start))
    source = fss.rule_memory[entry_rule[np.repeat(np.arange(fss.choice_action.size),
                                                   np.diff(fss.update_start))]]
    graph = sp.csr_matrix(
        (np.ones(source.size, dtype=np.int8),
         (np.searchsorted(named, source), np.searchsorted(named, fss.update_node))),
        shape=(named.size, named.size))
    start = int(np.searchsorted(named, fss.initial_memory))
    order = csgraph.breadth_first_order(graph, start, directed=True, return_predecessors=False)
    return np.asarray(named[np.sort(order)], dtype=np.int64)


@dataclass(eq=False)
class _Rows:
    """The product's rows as they are collected (mutable while the phases fill it): matrix
    entries in parts (row, column, value), each row's action (0 where a strategy mixes several),
    the (row, model choice, weight) triples that mix action rewards, and per strategy the product
    states for which it has no rule (a placeholder self-loop keeps their rows stochastic)."""

    rows: list[np.ndarray]
    cols: list[np.ndarray]
    vals: list[np.ndarray]
    action: np.ndarray
    weights: list[tuple[np.ndarray, np.ndarray, np.ndarray]]
    missing: list[np.ndarray]

    @classmethod
    def empty(cls, num_rows: int) -> _Rows:
        return cls([], [], [], np.zeros(num_rows, dtype=np.int32), [], [])

    def add(self, rows: np.ndarray, cols: np.ndarray, vals: np.ndarray) -> None:
        self.rows.append(rows)
        self.cols.append(cols)
        self.vals.append(vals)

    def matrix(self, layout: _Layout) -> sp.csr_matrix:
        """All rows over all S * K product states (duplicates summed)."""
        rows = np.concatenate(self.rows) if self.rows else np.zeros(0, np.int64)
        cols = np.concatenate(self.cols) if self.cols else np.zeros(0, np.int64)
        vals = np.concatenate(self.vals) if self.vals else np.zeros(0)
        N = layout.num_states * layout.K
        full = sp.csr_matrix((vals, (rows, cols)), shape=(layout.num_rows, N))
        full.sum_duplicates()
        return full


def _free_choices(model: ExplicitModel, layout: _Layout, out: _Rows) -> None:
    """Choices of players without a strategy: copied for every memory, the memory unchanged."""
    rg, T, choice_states = model.row_groups, model.transitions, model.choice_states
    K, memories, row_start = layout.K, layout.memories, layout.row_start
    free = np.flatnonzero(layout.fixed_by[choice_states] < 0)
    if not free.size:
        return
    Tf = T[free].tocoo()
    c = free[Tf.row]
    s = choice_states[c]
    rows = row_start[(s * K)[:, None] + memories] + (c - rg[s])[:, None]
    out.add(rows.ravel(), (Tf.col.astype(np.int64)[:, None] * K + memories).ravel(),
            np.repeat(Tf.data, K))
    free_rows = row_start[(choice_states[free] * K)[:, None] + memories] + (
        free - rg[choice_states[free]]
    )[:, None]
    out.action[free_rows.ravel()] = np.repeat(model.choice_actions[free], K)
    out.weights.append((free_rows.ravel(), np.repeat(free, K), np.ones(free.size * K)))


def _strategy_choices(
    model: ExplicitModel, strategies: tuple[BoundStrategy, ...], layout: _Layout, out: _Rows
) -> None:
    """States of players with a strategy: one mixed row per (state, memory), the strategy's
    mixture of the state's choices and memory updates (the module docstring's formula)."""
    T, choice_states = model.transitions, model.choice_states
    K, memories, row_start = layout.K, layout.memories, layout.row_start
    for i, b in enumerate(strategies):
        k, stride = layout.ks[i], layout.strides[i]
        orig = layout.nodes[i]  # compact node -> the strategy's node
        ci = np.flatnonzero(layout.fixed_by[choice_states] == i)
        owned_states = np.flatnonzero(layout.fixed_by == i)
        node = (memories // stride) % k  # [K], compact
        if owned_states.size:
            miss = b.missing_rule(
                np.broadcast_to(orig[node], (owned_states.size, K)).copy(),
                np.broadcast_to(owned_states[:, None], (owned_states.size, K)).copy(),
            )
            ps = (owned_states[:, None] * K + memories)[miss]
            out.missing.append(ps)
            # a placeholder self-loop keeps the rows stochastic until reachability decides
            out.add(row_start[ps], ps, np.ones(ps.size))
        if not ci.size:
            continue
        n = np.broadcast_to(orig[node], (ci.size, K)).copy()
        cc = np.broadcast_to(ci[:, None], (ci.size, K)).copy()
        e = b.entries(model, n, cc)  # [Ci, K], -1 where the choice is not played
        fss = b.fss
        w = np.where(e >= 0, fss.choice_probability[np.maximum(e, 0)], 0.0) \
            if fss.choice_probability.size else np.zeros(e.shape)
        s_ci = choice_states[ci]
        prow = row_start[(s_ci * K)[:, None] + memories]  # [Ci, K]
        out.weights.append((prow.ravel(), cc.ravel(), w.ravel()))
        sure = w == 1.0
        out.action[prow[sure]] = model.choice_actions[cc[sure]]
        Ti = T[ci].tocoo()
        # one product transition per (model transition, memory, memory update) with weight > 0:
        # value w·δ(n')·q, target s'·K + m + (n' - n)·stride; the memory updates are the
        # strategy's own lists, so the work is what the strategy writes, not k per pair
        t, m = np.nonzero(e[Ti.row] >= 0)  # [M] pairs of a transition and a memory
        rt = Ti.row[t]
        ee = e[rt, m]
        lo = fss.update_start[ee]
        num = fss.update_start[ee + 1] - lo
        wv, qv, pr = w[rt, m], Ti.data[t], prow[rt, m]
        base = Ti.col.astype(np.int64)[t] * K + m - node[m] * stride
        if np.all(num == 1):  # one next node each (deterministic updates): nothing to expand
            u = lo
        else:
            pick = np.repeat(np.arange(t.size), num)
            u = np.repeat(lo - np.cumsum(num) + num, num) + np.arange(int(num.sum()))
            wv, qv, pr, base = wv[pick], qv[pick], pr[pick], base[pick]
        val = wv * fss.update_probability[u] * qv  # (w·δ)·q, as the dense product computed it
        # every target is an entered node; all k entered: compact and own numbers agree
        target = fss.update_node[u] if orig.size == fss.memory_size \
            else np.searchsorted(orig, fss.update_node[u])
        keep = val > 0
        out.add(pr[keep], (base + target * stride)[keep], val[keep])


@dataclass(frozen=True, eq=False)
class _Reach:
    """The reachable part: ``keep_states``: int64[P] its product states in order; ``new_index``:
    int64[S * K] their numbers (-1 elsewhere); ``keep_rows``: bool[rows], the rows of kept states;
    ``init``: int64[I], the product state (before renumbering) of each of the model's initial
    states."""

    keep_states: np.ndarray
    new_index: np.ndarray
    keep_rows: np.ndarray
    init: np.ndarray


def _reachable_part(
    model: ExplicitModel,
    strategies: tuple[BoundStrategy, ...],
    layout: _Layout,
    rows: _Rows,
    full: sp.csr_matrix,
) -> _Reach:
    """The product states reachable from the initial ones (one breadth-first search from a
    virtual root); a reached state for which a strategy has no rule is an error."""
    K, N = layout.K, layout.num_states * layout.K
    m0 = sum(int(np.searchsorted(layout.nodes[i], b.fss.initial_memory)) * layout.strides[i]
             for i, b in enumerate(strategies))
    init = model.initial_states * K + m0
    row_state = np.repeat(np.arange(N, dtype=np.int64), layout.counts)
    coo = full.tocoo()
    src = np.concatenate([row_state[coo.row], np.full(init.size, N)])
    dst = np.concatenate([coo.col.astype(np.int64), init])
    graph = sp.csr_matrix((np.ones(src.size, dtype=np.int8), (src, dst)), shape=(N + 1, N + 1))
    order = csgraph.breadth_first_order(graph, N, directed=True, return_predecessors=False)
    reached = np.zeros(N + 1, dtype=bool)
    reached[order] = True
    reached = reached[:N]
    for i, ps in enumerate(rows.missing):
        hit = ps[reached[ps]]
        if hit.size:
            _missing_rule_error(model, strategies[i], int(hit[0]), K, layout.strides[i],
                                layout.nodes[i])
    keep_states = np.flatnonzero(reached)
    new_index = np.full(N, -1, dtype=np.int64)
    new_index[keep_states] = np.arange(keep_states.size)
    return _Reach(keep_states, new_index, reached[row_state], init)


def _mixed_rewards(
    model: ExplicitModel, layout: _Layout, rows: _Rows, reach: _Reach, state_of: np.ndarray
) -> tuple[RewardModel, ...]:
    """The model's reward structures on the product: state rewards copied, action rewards mixed
    by the strategies' weights."""
    parts = rows.weights
    rw_rows = np.concatenate([r for r, _, _ in parts]) if parts else np.zeros(0, np.int64)
    rw_choice = np.concatenate([c for _, c, _ in parts]) if parts else np.zeros(0, np.int64)
    rw_w = np.concatenate([w for _, _, w in parts]) if parts else np.zeros(0)
    rewards = []
    for rm in model.reward_models:
        choice = None
        if rm.choice is not None:
            mixed = np.bincount(
                rw_rows, weights=rw_w * rm.choice[rw_choice], minlength=layout.num_rows
            )
            choice = mixed[reach.keep_rows]
        state = rm.state[state_of] if rm.state is not None else None
        rewards.append(RewardModel(rm.name, state=state, choice=choice))
    return tuple(rewards)


def _assemble(
    model: ExplicitModel,
    strategies: tuple[BoundStrategy, ...],
    layout: _Layout,
    rows: _Rows,
    full: sp.csr_matrix,
    reach: _Reach,
) -> StrategyProduct:
    """The reachable product as a validated model, renumbered in product-state order."""
    K, ks, strides = layout.K, layout.ks, layout.strides
    keep_states, new_index, keep_rows = reach.keep_states, reach.new_index, reach.keep_rows
    sub = full[keep_rows]
    sub = sp.csr_matrix((sub.data, new_index[sub.indices], sub.indptr),
                        shape=(sub.shape[0], keep_states.size))
    sub.sort_indices()
    new_rg = np.concatenate([[0], np.cumsum(layout.counts[keep_states])]).astype(np.int64)

    state_of = keep_states // K
    mem = keep_states % K
    memory_of = np.stack([layout.nodes[i][(mem // strides[i]) % ks[i]] for i in range(len(ks))],
                         axis=1) \
        if ks else np.zeros((keep_states.size, 0), dtype=np.int64)
    rewards = _mixed_rewards(model, layout, rows, reach, state_of)

    new_init = new_index[reach.init]
    labels = {name: lab[state_of] for name, lab in model.labels.items() if name != "init"}
    init_label = np.zeros(keep_states.size, dtype=bool)
    init_label[new_init] = True
    labels["init"] = init_label
    all_fixed = bool(np.all(layout.fixed_by >= 0))
    product = make_model(
        _product_type(model, all_fixed),
        new_rg,
        sub,
        initial_states=np.unique(new_init),
        choice_actions=rows.action[keep_rows],
        action_names=model.action_names,
        state_players=model.state_players[state_of],
        player_names=model.player_names,
        observations=tuple(
            Observation(o.player, o.state_ids[state_of], o.names, o.values)
            for o in model.observations
        ),
        labels=labels,
        reward_models=rewards,
        variable_names=model.variable_names,
        boolean_variables=model.boolean_variables,
        state_values=(
            model.state_values[state_of] if model.state_values.shape[0] == layout.num_states
            else None
        ),
        deadlocks=np.flatnonzero(np.isin(state_of, model.deadlocks)),
    )
    return StrategyProduct(product, state_of, memory_of, strategies, new_init)


def _missing_rule_error(
    model: ExplicitModel, b: BoundStrategy, ps: int, K: int, stride: int, nodes: np.ndarray
) -> None:
    s, m = divmod(ps, K)
    n = int(nodes[(m // stride) % nodes.size])
    fss = b.fss
    raise StrategyError(
        f"no rule for memory {n} under the observation "
        f"{b.view.describe(int(b.view.state_obs[s]))}, "
        f"which player {b.view.name!r} reaches under the strategies (e.g. in state "
        f"{_state_text(model, s)})",
        path="rules",
        file=fss.source,
        hint=f'add a rule {{"memory": {n}, "observation": ...}} for it',
    )
