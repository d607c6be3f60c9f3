"""The game as the grid abstraction (:mod:`posgmc.synthesis.belief_grid`) expands it: per action
of the decision maker its continuing transitions, stopping gain and rewards, and the adversary's
decision rules tried at a vertex (deterministic ones and the uniform mixture over each state's
choices; any rule bounds the optimum). Computed once per problem; the rules and the exact
model's integer rows are cached as the exploration asks for them.
"""

from __future__ import annotations

import itertools

import numpy as np
import scipy.sparse as sp

from posgmc.strategies.binding import player_view
from posgmc.synthesis.belief import can_reach
from posgmc.synthesis.belief_rounding import UNIT
from posgmc.synthesis.parametric import Layout
from posgmc.synthesis.problem import Problem

__all__ = ["RULE_CAP", "Dynamics", "deterministic_picks"]


RULE_CAP = 64
"""The adversary's decision rules tried at one vertex at most (all of them when there are no
more; else the full-observation optimum's rule and its one-state deviations)."""


class Dynamics:
    """The game per action of its decision maker (continuing transitions, stopping gain,
    rewards), and the other states' choices (the adversary's, or a single one)."""

    def __init__(self, problem: Problem, adversary_rules: np.ndarray | None) -> None:
        model = problem.model
        self.model = model
        self.S = S = model.num_states
        layout = Layout.of(model, problem.player)
        view = player_view(model, problem.player)
        self.mask = layout.mask
        self.actions = layout.used_actions
        self.owned = (model.state_players == problem.player) if model.player_names else \
            np.ones(S, dtype=bool)
        obs_index = np.full(view.num_observations, -1, dtype=np.int64)
        obs_index[layout.used_obs] = np.arange(layout.used_obs.size)
        self.Z = Z = layout.used_obs.size
        # the group of each state: its observation index for the decision maker's states, Z for
        # the others (a vertex's support lies in one group)
        self.group = np.where(self.owned, obs_index[view.state_obs], Z)
        self.preferred = adversary_rules  # int64[S]: a choice per state (the first rule tried)
        # the rules of each support seen (many vertices share one support)
        self._rules: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        self._touches: dict[int, frozenset[int]] = {}
        if problem.rewards is None:
            # mass that cannot reach the target any more (within ``remain``) is worth 0
            self.cont = problem.remain & ~problem.target & can_reach(model, problem.target,
                                                                      problem.remain)
        else:
            self.cont = ~problem.target
        self.target = problem.target.astype(np.float64)
        act_index = np.full(len(model.action_names), -1, dtype=np.int64)
        act_index[layout.used_actions] = np.arange(layout.used_actions.size)
        self.choice_states = cs = model.choice_states  # computed once (a property)
        c_act = np.where(self.owned[cs], act_index[model.choice_actions], -1)
        keep = sp.diags(self.cont.astype(np.float64))
        self.P: list[sp.csr_matrix] = []
        self.stop: list[np.ndarray] = []
        self.reward: list[np.ndarray] = []
        self.choice_of: list[np.ndarray] = []  # per action: each state's choice (-1: none)
        # per action, the mass a state's choice sends to states that do not continue (the
        # target, or no way to it): exactly 0 where the float is (sums of nonnegative products)
        self.lost: list[np.ndarray] = []
        gone = (~self.cont).astype(np.float64)
        # the exact model is the stored one with every row scaled to sum to 1 (rows are checked
        # to within 1e-9): how far a stored probability lies from it, relatively
        sums = np.asarray(model.transitions.sum(axis=1)).ravel()
        k = np.diff(model.transitions.indptr).astype(np.float64)
        dev = float(np.max(np.abs(sums - 1.0) + 4.0 * (k + 2.0) * UNIT, initial=0.0))
        self.input_rel = 2.0 * dev / max(1.0 - dev, 0.5)
        self.integer_rows: dict[int, tuple[tuple[tuple[int, int], ...], int]] = {}
        for a in range(layout.used_actions.size):
            c = np.flatnonzero(c_act == a)
            at = np.full(S, -1, dtype=np.int64)
            at[cs[c]] = c
            self.choice_of.append(at)
            T = model.transitions[c].tocoo()
            Pa = sp.csr_matrix((T.data, (cs[c][T.row], T.col)), shape=(S, S))
            self.stop.append(np.asarray(Pa @ self.target).ravel())
            self.lost.append(np.asarray(Pa @ gone).ravel())
            self.P.append(sp.csr_matrix(Pa @ keep))
            r = np.zeros(S)
            if problem.rewards is not None:
                r[cs[c]] = problem.rewards[c]
            self.reward.append(r)
        self.T_cont = sp.csr_matrix(model.transitions @ keep)
        self.T_lost = np.asarray(model.transitions @ gone).ravel()
        # per choice: the reward of taking it (the adversary's rules pay theirs), and what the
        # target is worth when reached (1 for a probability, 0 for a reward: nothing more)
        self.choice_reward = np.zeros(model.num_choices) if problem.rewards is None else \
            np.asarray(problem.rewards, dtype=np.float64)
        self.stop_value = 1.0 if problem.rewards is None else 0.0
        self.discount = float(problem.discount)
        # a stop mass sums a belief's products with per-state stop masses, themselves sums over
        # a transition row: the longest such row bounds the inner sum's length
        self.row_terms = int(np.diff(model.transitions.indptr).max(initial=0)) + 3
        self.T_stop = np.asarray(model.transitions @ self.target).ravel()

    def integer_row(self, choice: int) -> tuple[tuple[tuple[int, int], ...], int]:
        """The exact model's row of ``choice`` (its stored probabilities scaled to sum to 1) as
        (column, integer numerator) pairs over one integer denominator (cached)."""
        found = self.integer_rows.get(choice)
        if found is None:
            T = self.model.transitions
            lo, hi = T.indptr[choice], T.indptr[choice + 1]
            ratios = [float(p).as_integer_ratio() for p in T.data[lo:hi]]
            den = max((d for _, d in ratios), default=1)  # powers of two: the largest is a
            nums = [n * (den // d) for n, d in ratios]    # common multiple
            found = self.integer_rows[choice] = (
                tuple(zip(T.indices[lo:hi].tolist(), nums)), sum(nums))
        return found

    def touches(self, choice: int) -> frozenset[int]:
        """The groups (:attr:`group`) of ``choice``'s continuing successors (cached)."""
        found = self._touches.get(choice)
        if found is None:
            T = self.T_cont
            found = self._touches[choice] = frozenset(
                self.group[T.indices[T.indptr[choice]:T.indptr[choice + 1]]].tolist())
        return found

    def rules(self, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The adversary's decision rules tried at a vertex on ``states``: (int64[m], the global
        ids of the support's choices; float64[k, m], each rule's probability of each of them,
        summing to 1 over each state's choices). Deterministic rules — all of them when there
        are at most :data:`RULE_CAP`, else the preferred rule and its one-state deviations —
        and the uniform mixture over each state's choices. Any rule, randomised or not, bounds
        the optimum (the adversary restricted can only do worse, and a randomised rule hides its
        choice from the decision maker). Computed once per support."""
        key = states.tobytes()
        found = self._rules.get(key)
        if found is None:
            found = self._rules[key] = self._rules_of(states)
        return found

    def _rules_of(self, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        rg = self.model.row_groups
        lo, hi = rg[states], rg[states + 1]
        n = hi - lo
        cols = np.concatenate([np.arange(a, b) for a, b in zip(lo.tolist(), hi.tolist())])
        offset = np.r_[0, np.cumsum(n)[:-1]]
        det = deterministic_picks(n, self._base(states, lo, hi)[None])[0]
        k = det.shape[0]
        varying = n > 1
        probs = np.zeros((k + (1 if varying.any() else 0), cols.size))
        probs[np.repeat(np.arange(k), states.size), (det + offset).ravel()] = 1.0
        if varying.any():
            probs[k] = np.repeat(1.0 / n, n)
        return cols, probs

    def _base(self, states: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """The local index of each state's preferred choice (its first where none is given),
        elementwise for ``states`` of any shape."""
        if self.preferred is None:
            return np.zeros(states.shape, dtype=np.int64)
        pref = self.preferred[states]
        out: np.ndarray = np.where((pref >= lo) & (pref < hi), pref - lo, 0)
        return out


def deterministic_picks(n: np.ndarray, base: np.ndarray) -> np.ndarray:
    """The adversary's deterministic rules (:meth:`Dynamics.rules`) at vertices whose support
    states offer ``n`` (int64[m]) choices each: int64[g, k, m], rule r's local choice per state
    at each of the g vertices. All combinations when there are at most :data:`RULE_CAP` (the
    same at every vertex, in lexicographic order over the states with a choice); else the
    preferred rule ``base`` (int64[g, m], local indices) and its one-state deviations, state by
    state, each state's other choices in their order, the first RULE_CAP in all."""
    g, m = base.shape
    varying = np.flatnonzero(n > 1)
    if float(np.prod(n[varying].astype(np.float64))) <= RULE_CAP:
        combos = list(itertools.product(*[range(int(n[i])) for i in varying.tolist()]))
        picks = np.asarray(combos, dtype=np.int64).reshape(len(combos), varying.size)
        det = np.zeros((picks.shape[0], m), dtype=np.int64)
        det[:, varying] = picks
        return np.broadcast_to(det, (g,) + det.shape).copy()
    # deviation j sets state who[j] to its alt[j]-th choice other than the preferred one
    who = np.repeat(varying, n[varying] - 1)[:RULE_CAP - 1]
    alt = np.concatenate([np.arange(int(n[i]) - 1) for i in varying.tolist()])[:RULE_CAP - 1]
    det = np.repeat(base[:, None, :], 1 + who.size, axis=1)
    at = base[:, who]
    det[:, 1 + np.arange(who.size), who] = alt + (alt >= at)
    return det
