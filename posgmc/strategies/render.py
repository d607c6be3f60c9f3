"""Finite-state strategies for people: a table and a DOT graph.

The table has one line per rule: memory node, observation, the action distribution and, per
action, the next memory node(s). The graph has one node per memory node and one edge per
(rule, action, next node), labelled ``observation / action : probability``.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from posgmc.strategies.fss import FiniteStateStrategy

__all__ = ["strategy_table", "strategy_dot"]


def _p(x: float) -> str:
    return f"{x:.6g}"


def _rules(fss: FiniteStateStrategy) -> Iterator[tuple[int, int, list[int]]]:
    """(memory node, observation, the actions played) of every rule, in observation order."""
    order = np.lexsort(fss.observation_values.T[::-1]) if fss.num_observations else np.zeros(0, int)
    for n in range(fss.memory_size):
        for z in order.tolist():
            if fss.has_rule[n, z]:
                played = sorted(
                    np.flatnonzero(fss.action[n, z] > 0).tolist(), key=lambda a: fss.actions[a]
                )
                yield n, z, played


def strategy_table(fss: FiniteStateStrategy) -> str:
    """The strategy as aligned text columns: memory, observation, action, next memory."""
    head = (f"strategy of player {fss.player!r}: {fss.memory_size} memory node"
            f"{'s' if fss.memory_size != 1 else ''}, initial node {fss.initial_memory}, "
            f"{'deterministic' if fss.is_deterministic else 'randomised'}")
    rows = [("memory", "observation", "action", "next memory")]
    for n, z, played in _rules(fss):
        action = ", ".join(
            f"{fss.actions[a] or '(unlabelled)'}: {_p(fss.action[n, z, a])}" for a in played
        )
        nxt = []
        for a in played:
            dist = fss.update[n, z, a]
            targets = np.flatnonzero(dist > 0)
            text = ", ".join(
                f"{m}: {_p(dist[m])}" if dist[m] < 1 else str(m) for m in targets.tolist()
            )
            nxt.append(f"{fss.actions[a] or '(unlabelled)'} -> {text}")
        rows.append((str(n), fss.describe_observation(z), action, "; ".join(nxt)))
    widths = [max(len(r[i]) for r in rows) for i in range(3)]
    lines = [head]
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
    for n in range(fss.memory_size):
        lines.append(f"  n{n} [label={_quote(str(n))}];")
    for n, z, played in _rules(fss):
        for a in played:
            for m in np.flatnonzero(fss.update[n, z, a] > 0).tolist():
                p = fss.action[n, z, a] * fss.update[n, z, a, m]
                label = (
                    f"{fss.describe_observation(z)} / {fss.actions[a] or '(unlabelled)'} : {_p(p)}"
                )
                lines.append(f"  n{n} -> n{m} [label={_quote(label)}];")
    lines.append("}")
    return "\n".join(lines) + "\n"
