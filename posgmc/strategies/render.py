"""Finite-state strategies for people: a table and a DOT graph.

The table opens with a summary line (player, memory nodes, observations, rules, initial node,
deterministic or randomised), then has one line per rule: memory node, observation, the action
distribution and, per action, the next memory node(s); it can be restricted to memory nodes and
observations, and made compact (observations with the same choice share a line). The graph has
one node per memory node and one edge per (rule, action, next node), labelled
``observation / action : probability``.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping

import numpy as np

from posgmc.errors import InputError
from posgmc.strategies.files import rules_in_order
from posgmc.strategies.fss import FiniteStateStrategy

__all__ = ["matching_observations", "strategy_dot", "strategy_summary", "strategy_table"]


def _p(x: float) -> str:
    return f"{x:.6g}"


def _rules(fss: FiniteStateStrategy, nodes: Iterable[int] | None = None,
           observations: np.ndarray | None = None) -> Iterator[tuple[int, int, list[int]]]:
    """(memory node, observation, the played-action entries by label) of every rule, in memory
    and observation order; only memory ``nodes`` (in their order) and the observations where
    ``observations`` (bool[Z]) holds, when given. Linear in the rules written."""
    order = rules_in_order(fss)
    memory = fss.rule_memory[order]
    if nodes is None:
        chosen = order.tolist()
    else:
        chosen = []
        for n in nodes:
            lo, hi = np.searchsorted(memory, n, "left"), np.searchsorted(memory, n, "right")
            chosen += order[lo:hi].tolist()
    c_start, c_act = fss.choice_start.tolist(), fss.choice_action.tolist()
    for r in chosen:
        z = int(fss.rule_observation[r])
        if observations is None or observations[z]:
            entries = sorted(range(c_start[r], c_start[r + 1]),
                             key=lambda e: fss.actions[c_act[e]])
            yield int(fss.rule_memory[r]), z, entries


def strategy_summary(fss: FiniteStateStrategy) -> str:
    """One line: whose, how many memory nodes, observations and rules, the initial node, and
    whether every rule is deterministic."""
    k, rules = fss.memory_size, fss.num_rules
    return (f"strategy of player {fss.player!r}: {k} memory node{'s' if k != 1 else ''}, "
            f"{fss.num_observations} observation{'s' if fss.num_observations != 1 else ''}, "
            f"{rules} rule{'s' if rules != 1 else ''}, initial node {fss.initial_memory}, "
            f"{'deterministic' if fss.is_deterministic else 'randomised'}")


def matching_observations(fss: FiniteStateStrategy, wanted: Mapping[str, int]) -> np.ndarray:
    """bool[Z]: the observations whose observables have the ``wanted`` values (observable name
    -> value; for a strategy without observables, ``{"": id}``).

    Raises:
        InputError: a name that is not one of the strategy's observables.
    """
    columns = list(fss.observables) or [""]
    out = np.ones(fss.num_observations, dtype=bool)
    for name, value in wanted.items():
        if name not in columns:
            raise InputError(f"{name!r} is not an observable of the strategy (its observables: "
                             f"{', '.join(fss.observables) or 'none, observations are ids'})")
        out &= fss.observation_values[:, columns.index(name)] == value
    return out


def _choice_text(fss: FiniteStateStrategy, entries: list[int]) -> tuple[str, str]:
    """The action column and the next-memory column of one rule (its played-action entries)."""
    labels = [fss.actions[int(fss.choice_action[e])] or "(unlabelled)" for e in entries]
    action = ", ".join(
        f"{label}: {_p(float(fss.choice_probability[e]))}" for label, e in zip(labels, entries)
    )
    nxt = []
    for label, e in zip(labels, entries):
        lo, hi = int(fss.update_start[e]), int(fss.update_start[e + 1])
        text = ", ".join(
            f"{m}: {_p(q)}" if q < 1 else str(m)
            for m, q in zip(fss.update_node[lo:hi].tolist(),
                            fss.update_probability[lo:hi].tolist())
        )
        nxt.append(f"{label} -> {text}")
    return action, "; ".join(nxt)


def _values_text(values: frozenset[int]) -> str:
    """``{1, 2, 3}`` -> ``1..3``; ``{0, 2}`` -> ``0|2``."""
    ordered = sorted(values)
    if len(ordered) > 2 and ordered[-1] - ordered[0] == len(ordered) - 1:
        return f"{ordered[0]}..{ordered[-1]}"
    return "|".join(map(str, ordered))


def _boxes(points: list[tuple[int, ...]]) -> list[tuple[frozenset[int], ...]]:
    """Disjoint boxes (one value set per coordinate) whose union is exactly ``points``: points
    that differ in one coordinate only are merged, coordinate after coordinate, until nothing
    merges."""
    boxes = [tuple(frozenset((v,)) for v in p) for p in points]
    changed = True
    while changed and len(boxes) > 1:
        changed = False
        for j in range(len(boxes[0])):
            merged: dict[tuple[frozenset[int], ...], set[int]] = {}
            for box in boxes:
                rest = box[:j] + box[j + 1:]
                merged.setdefault(rest, set()).update(box[j])
            if len(merged) < len(boxes):
                changed = True
            # a box may only merge with boxes equal in every other coordinate: still disjoint
            boxes = [rest[:j] + (frozenset(values),) + rest[j:] for rest, values in merged.items()]
    return boxes


def strategy_table(fss: FiniteStateStrategy, *, nodes: Iterable[int] | None = None,
                   observations: np.ndarray | None = None, compact: bool = False) -> str:
    """The strategy as aligned text columns after its summary line: memory, observation, action,
    next memory; only memory ``nodes`` and the observations where ``observations`` (bool[Z])
    holds, when given. ``compact``: in each memory node, observations with the same action and
    next memory share a row, written as the ranges of their observables' values
    (``{x=1..3, phase=2}``) that cover exactly them."""
    rows = [("memory", "observation", "action", "next memory")]
    if compact:
        groups: dict[tuple[int, str, str], list[tuple[int, ...]]] = {}
        for n, z, played in _rules(fss, nodes, observations):
            groups.setdefault((n, *_choice_text(fss, played)), []).append(
                tuple(fss.observation_values[z].tolist()))
        names = list(fss.observables)
        for (n, action, nxt), points in groups.items():
            for box in _boxes(points):
                if names:
                    what = "{" + ", ".join(f"{name}={_values_text(v)}"
                                           for name, v in zip(names, box)) + "}"
                else:
                    what = f"observation {_values_text(box[0])}"
                rows.append((str(n), what, action, nxt))
    else:
        for n, z, played in _rules(fss, nodes, observations):
            rows.append((str(n), fss.describe_observation(z), *_choice_text(fss, played)))
    widths = [max(len(r[i]) for r in rows) for i in range(3)]
    lines = [strategy_summary(fss)]
    for r in rows:
        lines.append("  ".join(r[i].ljust(widths[i]) for i in range(3)) + "  " + r[3])
    return "\n".join(lines) + "\n"


def _quote(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def strategy_dot(fss: FiniteStateStrategy) -> str:
    """A DOT digraph: memory nodes, and an edge per rule, action and next node."""
    lines = [
        f"digraph {_quote('fss ' + fss.player)} {{",
        "  rankdir=LR;",
        "  node [shape=circle];",
        "  start [shape=point];",
        f"  start -> n{fss.initial_memory};",
    ]
    # every node; for a strategy with far more nodes than rules, those its rules name
    if fss.memory_size > 2 * (fss.num_rules + 1):
        named = [np.array([fss.initial_memory]), fss.rule_memory, fss.update_node]
        shown: list[int] = np.unique(np.concatenate(named)).tolist()
    else:
        shown = list(range(fss.memory_size))
    for n in shown:
        lines.append(f"  n{n} [label={_quote(str(n))}];")
    u_start, u_node = fss.update_start.tolist(), fss.update_node.tolist()
    u_prob = fss.update_probability.tolist()
    c_act, c_prob = fss.choice_action.tolist(), fss.choice_probability.tolist()
    for n, z, entries in _rules(fss):
        for e in entries:
            for u in range(u_start[e], u_start[e + 1]):
                label = (f"{fss.describe_observation(z)} / "
                         f"{fss.actions[c_act[e]] or '(unlabelled)'} : {_p(c_prob[e] * u_prob[u])}")
                lines.append(f"  n{n} -> n{u_node[u]} [label={_quote(label)}];")
    lines.append("}")
    return "\n".join(lines) + "\n"
