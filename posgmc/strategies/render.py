"""Finite-state strategies for people: a table and a DOT graph.

The table has one line per rule: memory node, observation, the action distribution and, per
action, the next memory node(s). The graph has one node per memory node and one edge per
(rule, action, next node), labelled ``observation / action : probability``.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from posgmc.strategies.files import rules_in_order
from posgmc.strategies.fss import FiniteStateStrategy

__all__ = ["strategy_table", "strategy_dot"]


def _p(x: float) -> str:
    return f"{x:.6g}"


def _rules(fss: FiniteStateStrategy) -> Iterator[tuple[int, int, list[tuple[str, float, str]]]]:
    """(memory node, observation, [(action, probability, next memory text)]) of every rule, in
    memory and observation order; linear in the rules written."""
    labels = [a or "(unlabelled)" for a in fss.actions]
    c_start, c_act = fss.choice_start.tolist(), fss.choice_action.tolist()
    c_prob = fss.choice_probability.tolist()
    u_start, u_node = fss.update_start.tolist(), fss.update_node.tolist()
    u_prob = fss.update_probability.tolist()
    for r in rules_in_order(fss).tolist():
        entries = sorted(range(c_start[r], c_start[r + 1]), key=lambda e: fss.actions[c_act[e]])
        played = []
        for e in entries:
            nxt = ", ".join(
                f"{u_node[u]}: {_p(u_prob[u])}" if u_prob[u] < 1 else str(u_node[u])
                for u in range(u_start[e], u_start[e + 1])
            )
            played.append((labels[c_act[e]], c_prob[e], nxt))
        yield int(fss.rule_memory[r]), int(fss.rule_observation[r]), played


def strategy_table(fss: FiniteStateStrategy) -> str:
    """The strategy as aligned text columns: memory, observation, action, next memory."""
    head = (f"strategy of player {fss.player!r}: {fss.memory_size} memory node"
            f"{'s' if fss.memory_size != 1 else ''}, initial node {fss.initial_memory}, "
            f"{'deterministic' if fss.is_deterministic else 'randomised'}")
    rows = [("memory", "observation", "action", "next memory")]
    for n, z, played in _rules(fss):
        action = ", ".join(f"{a}: {_p(p)}" for a, p, _ in played)
        nxt = "; ".join(f"{a} -> {text}" for a, _, text in played)
        rows.append((str(n), fss.describe_observation(z), action, nxt))
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
    # every node; for a strategy with far more nodes than rules, those its rules name
    if fss.memory_size > 2 * (fss.num_rules + 1):
        named = [np.array([fss.initial_memory]), fss.rule_memory, fss.update_node]
        nodes: list[int] = np.unique(np.concatenate(named)).tolist()
    else:
        nodes = list(range(fss.memory_size))
    for n in nodes:
        lines.append(f"  n{n} [label={_quote(str(n))}];")
    u_start, u_node = fss.update_start.tolist(), fss.update_node.tolist()
    u_prob = fss.update_probability.tolist()
    c_start, c_act = fss.choice_start.tolist(), fss.choice_action.tolist()
    c_prob = fss.choice_probability.tolist()
    for r in rules_in_order(fss).tolist():
        n, z = int(fss.rule_memory[r]), int(fss.rule_observation[r])
        for e in sorted(range(c_start[r], c_start[r + 1]), key=lambda e: fss.actions[c_act[e]]):
            for u in range(u_start[e], u_start[e + 1]):
                label = (f"{fss.describe_observation(z)} / "
                         f"{fss.actions[c_act[e]] or '(unlabelled)'} : {_p(c_prob[e] * u_prob[u])}")
                lines.append(f"  n{n} -> n{u_node[u]} [label={_quote(label)}];")
    lines.append("}")
    return "\n".join(lines) + "\n"
