"""Freeze an exploration into an :class:`~posgmc.model.explicit.ExplicitModel`.

Builds the transition matrix (CSR, rows = choices grouped by state, duplicate targets of a choice
summed as Storm does before counting transitions), merges the choices of a DTMC state into one
distribution weighted ``1/number of choices`` (``PrismNextStateGenerator::expand``), evaluates
labels, rewards and observations over all states in chunks, and assigns each state of a game to
its player.

Player of a state (PRISM-games, ``ModulesFileModelGenerator.getPlayerOwningState``): the player
owning its enabled choices, an unlabelled choice being owned by the player owning its module and a
labelled one by the player owning its action; choices of two players in one state are an error;
unowned choices next to owned ones are allowed (the state goes to the owner; Storm is stricter and
rejects any enabled unowned choice); a state whose choices are all unowned must have exactly one
choice and goes to the first player, as do deadlock states.

Observations: each partially observing player gets an :class:`Observation`: a pomdp's top-level
observables belong to its agent (player 0); in a posg each player declares its own; in an smg with
top-level observables (PAYNT's POSMG sources) the observation is attached to every player without
observables of its own, and the property's coalition later decides which player is partial.
Observation ids are dense and numbered by first appearance in state order. States with the same
observation that belong to the observing player must offer the same set of action labels.
"""

from __future__ import annotations

from collections.abc import Sequence
from types import MappingProxyType

import numpy as np
import scipy.sparse as sp

from posgmc.compiler.compile_expr import Columns, CompiledExpr, EvaluationError, ExprType
from posgmc.compiler.explore import Exploration
from posgmc.compiler.options import BuildOptions, ValidationMode
from posgmc.compiler.program import UNOWNED, Generator, GeneratorKind, Program
from posgmc.errors import BuildError, SourceSpan, UnsupportedError
from posgmc.model.actions import (
    action_signatures,
    conflict_message,
    labels_of,
    observation_action_conflict,
)
from posgmc.model.explicit import ExplicitModel, Observation, RewardModel
from posgmc.semantics import operators as ops
from posgmc.semantics.flat import FlatObservable
from posgmc.syntax.ast import NO_SPAN, ModelType

__all__ = ["assemble"]

_CHUNK = 1 << 20  # states per chunk when evaluating labels, rewards, observations


def _span(span: SourceSpan) -> SourceSpan | None:
    return None if span == NO_SPAN else span


class _StateEvaluator:
    """Evaluates compiled expressions over all states, a chunk of states at a time."""

    def __init__(self, program: Program, state_keys: np.ndarray) -> None:
        self.program = program
        self.keys = state_keys
        self.num_states = int(state_keys.shape[0])

    def chunks(self) -> Sequence[tuple[int, int]]:
        return [(lo, min(self.num_states, lo + _CHUNK)) for lo in range(0, self.num_states, _CHUNK)]

    def columns(self, lo: int, hi: int) -> Columns:
        return Columns(self.program.encoding.decode(self.keys[lo:hi]), hi - lo)

    def evaluate_many(
        self, exprs: Sequence[CompiledExpr], dtypes: Sequence[type]
    ) -> list[np.ndarray]:
        outs: list[np.ndarray] = [np.empty(self.num_states, dtype=d) for d in dtypes]
        for lo, hi in self.chunks():
            cols = self.columns(lo, hi)
            for e, out in zip(exprs, outs):
                out[lo:hi] = self._eval(e, cols, lo)
        return outs

    def _eval(self, e: CompiledExpr, cols: Columns, lo: int) -> np.ndarray:
        try:
            return e.evaluate(cols)
        except EvaluationError as err:
            state = self.describe(lo + err.row)
            raise BuildError(f"{err.message} in state {state}", _span(err.span)) from None

    def describe(self, s: int) -> str:
        values = self.program.encoding.decode_values(self.keys[s : s + 1])[0]
        return self.program.describe([int(x) for x in values])


def assemble(
    program: Program, exp: Exploration, options: BuildOptions
) -> tuple[ExplicitModel, list[str]]:
    """Turn the exploration into the frozen model.

    Args:
        program: the compiled model.
        exp: the exploration result (consumed: its big arrays are released along the way).
        options: observation building and validation settings.

    Returns:
        The model and the warnings (e.g. fixed deadlocks).

    Raises:
        BuildError: two players' choices in one state, several unowned choices in one state,
            states with one observation but different action labels, failing expressions.
        UnsupportedError: a double-valued observable.
    """
    flat = program.flat
    model_type = flat.model_type
    num_states = int(exp.state_keys.shape[0])
    warnings: list[str] = []
    evaluator = _StateEvaluator(program, exp.state_keys)

    gens = list(program.generators) + [program.deadlock_generator]
    gen_action = np.array([g.action for g in gens], dtype=np.int32)
    choices_per_state = exp.choice_counts
    row_groups = np.zeros(num_states + 1, dtype=np.int64)
    np.cumsum(choices_per_state, out=row_groups[1:])
    num_choices = int(row_groups[-1])
    choice_actions = gen_action[exp.choice_gen]
    deadlock_gen = program.deadlock_generator.index

    # -- rewards (on the unmerged choices) ------------------------------------------------------
    reward_models = _rewards(program, evaluator, exp, choice_actions, deadlock_gen)

    # -- players -----------------------------------------------------------------------------
    player_names = tuple(p.name for p in flat.players) if model_type.is_game else ()
    if model_type.is_game:
        gen_owner = np.array([g.owner for g in gens], dtype=np.int32)
        state_players = _players(
            program,
            evaluator,
            gens,
            exp.choice_gen,
            gen_owner[exp.choice_gen],
            row_groups,
            choices_per_state,
        )
    else:
        state_players = np.zeros(num_states, dtype=np.int32)
    exp.choice_gen = np.zeros(0, dtype=exp.choice_gen.dtype)

    # -- transition matrix ----------------------------------------------------------------------
    indptr = exp.indptr
    if model_type is ModelType.DTMC:
        # one distribution per state: every enabled choice weighted 1/(number of choices)
        multi = np.flatnonzero(choices_per_state > 1)
        if multi.size:
            branch_counts = np.diff(indptr)
            per_state_branches = np.add.reduceat(branch_counts, row_groups[:-1])
            weights = np.repeat(1.0 / choices_per_state, per_state_branches)
            exp.probs *= weights
            del weights, branch_counts
            state_ptr = np.zeros(num_states + 1, dtype=indptr.dtype)
            np.cumsum(per_state_branches, out=state_ptr[1:])
            indptr = state_ptr
        # a merged choice keeps its action only if all merged choices share it
        amin = np.minimum.reduceat(choice_actions, row_groups[:-1])
        amax = np.maximum.reduceat(choice_actions, row_groups[:-1])
        choice_actions = np.where(amin == amax, amin, 0).astype(np.int32)
        for rm_i, rm in enumerate(reward_models):
            if rm.choice is not None:
                sums = np.add.reduceat(rm.choice, row_groups[:-1])
                reward_models[rm_i] = RewardModel(rm.name, rm.state, sums / choices_per_state)
        row_groups = np.arange(num_states + 1, dtype=np.int64)
        num_rows = num_states
    else:
        num_rows = num_choices
    exp.indptr = np.zeros(0, dtype=indptr.dtype)
    targets, probs = exp.targets, exp.probs
    exp.targets, exp.probs = np.zeros(0, dtype=targets.dtype), np.zeros(0)
    transitions = sp.csr_matrix((probs, targets, indptr), shape=(num_rows, num_states), copy=False)
    del probs, targets, indptr
    transitions.sum_duplicates()

    # -- labels ----------------------------------------------------------------------------
    label_exprs = [program.compile(e) for _, e in flat.labels]
    label_arrays = evaluator.evaluate_many(label_exprs, [np.bool_] * len(label_exprs))
    labels = {name: arr for (name, _), arr in zip(flat.labels, label_arrays)}
    init_label = np.zeros(num_states, dtype=bool)
    init_label[exp.initial] = True
    labels["init"] = init_label
    dead_label = np.zeros(num_states, dtype=bool)
    dead_label[exp.deadlocks] = True
    labels["deadlock"] = dead_label
    if exp.deadlocks.size:
        n = int(exp.deadlocks.size)
        warnings.append(f"{n} deadlock state{'s' if n != 1 else ''} fixed with self-loops")

    # -- state values ---------------------------------------------------------------------------
    state_values = np.empty((num_states, len(program.variable_names)), dtype=np.int64)
    for lo, hi in evaluator.chunks():
        state_values[lo:hi] = program.encoding.decode_values(exp.state_keys[lo:hi])

    # -- observations -----------------------------------------------------------------------
    observations: tuple[Observation, ...] = ()
    if options.build_observations:
        observations = _observations(
            program, evaluator, state_players, choice_actions, row_groups, player_names
        )

    model = ExplicitModel(
        model_type=model_type,
        initial_states=exp.initial.astype(np.int64),
        row_groups=row_groups,
        transitions=transitions,
        choice_actions=choice_actions.astype(np.int32, copy=False),
        action_names=program.action_names,
        state_players=state_players,
        player_names=player_names,
        observations=observations,
        labels=MappingProxyType(labels),
        reward_models=tuple(reward_models),
        variable_names=program.variable_names,
        state_values=state_values,
        deadlocks=exp.deadlocks.astype(np.int64),
        boolean_variables=frozenset(
            n for n, t in zip(program.variable_names, program.variable_types) if t is ExprType.BOOL
        ),
    )
    if options.validation is ValidationMode.ALWAYS or (
        options.validation is ValidationMode.AUTO
        and model.num_transitions <= options.validate_limit
    ):
        model.validate()
    return model, warnings


# ---------------------------------------------------------------------------------------------
# rewards
# ---------------------------------------------------------------------------------------------


def _rewards(
    program: Program,
    evaluator: _StateEvaluator,
    exp: Exploration,
    choice_actions: np.ndarray,
    deadlock_gen: int,
) -> list[RewardModel]:
    """State rewards (sum over matching items) and action rewards per (unmerged) choice."""
    out: list[RewardModel] = []
    action_id = {a: i for i, a in enumerate(program.action_names)}
    num_choices = int(choice_actions.size)
    choice_src: np.ndarray | None = None
    for struct in program.flat.rewards:
        state_items = [it for it in struct.items if not it.is_action]
        action_items = [it for it in struct.items if it.is_action]
        state = None
        if state_items:
            state = np.zeros(evaluator.num_states)
            guards = [program.compile(it.guard) for it in state_items]
            values = [program.compile(it.value) for it in state_items]
            for lo, hi in evaluator.chunks():
                cols = evaluator.columns(lo, hi)
                for g, v in zip(guards, values):
                    state[lo:hi] += _guarded(evaluator, g, v, cols, lo)
        choice = None
        if action_items:
            # items with a constant guard and value add a constant per action: one gather
            per_action = np.zeros(len(program.action_names))
            varying = []
            for it in action_items:
                a = action_id.get(it.action if it.action is not None else "")
                if a is None:
                    continue  # an action no command has: the item applies to no choice
                g = program.compile(it.guard)
                v = program.compile(it.value)
                if g.constant is not None and v.constant is not None:
                    if g.constant:
                        per_action[a] += ops.to_float(v.constant)
                else:
                    varying.append((a, g, v))
            choice = per_action[choice_actions] if per_action.any() else np.zeros(num_choices)
            for a, g, v in varying:
                sel = np.flatnonzero(choice_actions == a)
                if sel.size == 0:
                    continue
                per_state = np.zeros(evaluator.num_states)
                for lo, hi in evaluator.chunks():
                    per_state[lo:hi] = _guarded(evaluator, g, v, evaluator.columns(lo, hi), lo)
                if choice_src is None:
                    choice_src = exp.choice_src
                choice[sel] += per_state[choice_src[sel]]
            if per_action[0] or any(a == 0 for a, _, _ in varying):
                # Storm gives the self-loop of a deadlock state no action reward
                choice[exp.choice_gen == deadlock_gen] = 0.0
        out.append(RewardModel(struct.name, state, choice))
    return out


def _guarded(
    evaluator: _StateEvaluator, g: CompiledExpr, v: CompiledExpr, cols: Columns, lo: int
) -> np.ndarray:
    """``guard ? value : 0`` as float64, evaluating the value only where the guard holds."""
    guard = evaluator._eval(g, cols, lo)
    out = np.zeros(cols.n)
    rows = np.flatnonzero(guard)
    if rows.size == cols.n:
        out[:] = evaluator._eval(v, cols, lo)
    elif rows.size:
        sub = cols.take(rows)
        try:
            out[rows] = v.evaluate(sub)
        except EvaluationError as err:
            state = evaluator.describe(lo + err.row)
            raise BuildError(f"{err.message} in state {state}", _span(err.span)) from None
    return out


# ---------------------------------------------------------------------------------------------
# players
# ---------------------------------------------------------------------------------------------


def _players(
    program: Program,
    evaluator: _StateEvaluator,
    gens: list[Generator],
    choice_gen: np.ndarray,
    owner: np.ndarray,
    row_groups: np.ndarray,
    choices_per_state: np.ndarray,
) -> np.ndarray:
    flat = program.flat
    num_players = len(flat.players)
    starts = row_groups[:-1]
    hi_owner = np.maximum.reduceat(owner, starts)
    lo_owner = np.minimum.reduceat(np.where(owner == UNOWNED, num_players, owner), starts)
    conflict = (hi_owner != UNOWNED) & (lo_owner != hi_owner)
    if conflict.any():
        s = int(np.flatnonzero(conflict)[0])
        p1, p2 = int(lo_owner[s]), int(hi_owner[s])
        c = int(starts[s]) + int(np.flatnonzero(owner[starts[s] : row_groups[s + 1]] == p2)[0])
        raise BuildError(
            f"state {evaluator.describe(s)} has choices of two players, "
            f"{flat.players[p1].name} and {flat.players[p2].name}",
            _span(gens[int(choice_gen[c])].span),
            hint="a state of a turn-based game must belong to one player: make the guards of the "
            "two players' commands exclusive (e.g. with a turn variable)",
        )
    unowned_multi = (hi_owner == UNOWNED) & (choices_per_state > 1)
    if unowned_multi.any():
        s = int(np.flatnonzero(unowned_multi)[0])
        rows = np.arange(int(starts[s]), int(row_groups[s + 1]))
        names = sorted({_choice_name(program, gens[int(choice_gen[c])]) for c in rows})
        raise BuildError(
            f"state {evaluator.describe(s)} has several choices ({', '.join(names)}) "
            "not owned by any player",
            _span(gens[int(choice_gen[rows[0]])].span),
            hint="add the modules or actions of these commands to a player ... endplayer block",
        )
    return np.where(hi_owner == UNOWNED, 0, hi_owner).astype(np.int32)


def _choice_name(program: Program, g: Generator) -> str:
    if g.action:
        return f"[{program.action_names[g.action]}]"
    if g.kind is GeneratorKind.ASYNC and g.command is not None:
        return f"[] of module {program.module_names[g.command.module]}"
    return "[]"


# ---------------------------------------------------------------------------------------------
# observations
# ---------------------------------------------------------------------------------------------


def _observations(
    program: Program,
    evaluator: _StateEvaluator,
    state_players: np.ndarray,
    choice_actions: np.ndarray,
    row_groups: np.ndarray,
    player_names: tuple[str, ...],
) -> tuple[Observation, ...]:
    flat = program.flat
    assignments: list[tuple[int, tuple[FlatObservable, ...]]] = []
    if flat.model_type is ModelType.POMDP:
        if flat.observables is not None:
            assignments.append((0, flat.observables))
    elif flat.model_type.is_game:
        for p, player in enumerate(flat.players):
            if player.observables is not None:
                assignments.append((p, player.observables))
            elif flat.observables is not None:
                assignments.append((p, flat.observables))
    if not assignments:
        return ()
    signatures = action_signatures(choice_actions, row_groups, len(program.action_names))
    cache: dict[int, tuple[np.ndarray, np.ndarray, tuple[str, ...]]] = {}
    out = []
    for p, observables in assignments:
        key = id(observables)
        if key not in cache:
            cache[key] = _observation_ids(program, evaluator, observables)
        ids, values, names = cache[key]
        owned = np.flatnonzero(state_players == p) if flat.model_type.is_game else None
        _check_same_actions(
            program,
            evaluator,
            ids,
            owned,
            signatures,
            choice_actions,
            row_groups,
            observables,
            p,
            player_names,
        )
        out.append(Observation(player=p, state_ids=ids, names=names, values=values))
    return tuple(out)


def _observation_ids(
    program: Program, evaluator: _StateEvaluator, observables: tuple[FlatObservable, ...]
) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """Dense ids (first appearance in state order), the value table, the observable names."""
    num_states = evaluator.num_states
    names = tuple(o.name for o in observables)
    if not observables:
        return np.zeros(num_states, dtype=np.int32), np.zeros((1, 0), dtype=np.int64), names
    exprs = []
    for o in observables:
        e = program.compile(o.expr)
        if e.type is ExprType.DOUBLE:
            raise UnsupportedError(
                f'observable "{o.name}" has a double value; only int and bool observables '
                "are supported",
                _span(o.span),
                hint="observe a rounded or compared value instead, e.g. floor(x) or x > 0.5",
            )
        exprs.append(e)
    columns = evaluator.evaluate_many(exprs, [np.int64] * len(exprs))
    # pack each row into one int64 (mixed radix over the observed ranges) when it fits
    packed = np.zeros(num_states, dtype=np.int64)
    radix = 1
    fits = True
    for col in columns:
        lo, hi = int(col.min()), int(col.max())
        size = hi - lo + 1
        if radix * size >= (1 << 62):
            fits = False
            break
        packed = packed * size + (col - lo)
        radix *= size
    if fits:
        _, first, inverse = np.unique(packed, return_index=True, return_inverse=True)
    else:
        table = np.stack(columns, axis=1)
        _, first, inverse = np.unique(table, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    order = np.argsort(first)
    rank = np.empty(first.size, dtype=np.int32)
    rank[order] = np.arange(first.size, dtype=np.int32)
    ids = rank[inverse]
    reps = first[order]
    values = np.stack([c[reps] for c in columns], axis=1).astype(np.int64)
    return ids.astype(np.int32), values, names


def _check_same_actions(
    program: Program,
    evaluator: _StateEvaluator,
    ids: np.ndarray,
    owned: np.ndarray | None,
    signatures: np.ndarray,
    choice_actions: np.ndarray,
    row_groups: np.ndarray,
    observables: tuple[FlatObservable, ...],
    player: int,
    player_names: tuple[str, ...],
) -> None:
    states = np.arange(ids.size) if owned is None else owned
    conflict = observation_action_conflict(ids, states, signatures)
    if conflict is None:
        return
    s, t = conflict
    who = f"player {player_names[player]}" if player_names else "the agent"
    span = observables[0].span if observables else NO_SPAN
    message, hint = conflict_message(
        evaluator.describe(s),
        evaluator.describe(t),
        who,
        int(ids[s]),
        labels_of(signatures[s], program.action_names),
        labels_of(signatures[t], program.action_names),
    )
    raise BuildError(message, _span(span), hint=hint)
