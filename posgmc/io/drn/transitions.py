"""The choice structure of a DRN model and its transition matrix.

A DTMC state has one choice, whose action line is optional; in the other models every action line
starts a choice, and every transition line belongs to the action line above it. Transition lines
are ``<target> : <probability>`` with decimal, fractional ``p/q`` or placeholder ``$name``
values. Transitions to the same target within one choice are summed, as Storm does; zero
probabilities are dropped. The transition count is the number of distinct (choice, target)
pairs, which is Storm's ``nr_transitions``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from posgmc.errors import PosgmcError
from posgmc.io._text import STR, parse_values
from posgmc.io.drn.body import Actions, Body
from posgmc.io.drn.header import Header
from posgmc.io.drn.source import DrnText

__all__ = ["Choices", "dtmc_choices", "nondeterministic_choices", "parse_transitions"]


@dataclass(frozen=True)
class Choices:
    """The choice structure: row groups, and which choice each transition and action line is."""

    row_groups: np.ndarray  # int64[S + 1]
    choice_of_trans: np.ndarray  # int64[T]: choice of each transition line
    trans_idx: np.ndarray  # int64[T]: body index of each transition line
    names: np.ndarray  # StringDType[C]: action token of each choice ("" if none)
    choice_lines: np.ndarray  # int64[C]: file line of each choice's action (or state) line
    action_choice: np.ndarray  # int64[A]: choice of each action line


def dtmc_choices(
    drn: DrnText,
    header: Header,
    body: Body,
    state_idx: np.ndarray,
    action_idx: np.ndarray,
    actions: Actions,
) -> Choices:
    """One choice per state; its action line is optional."""
    num_states = int(state_idx.size)
    action_states = body.state_of(action_idx)
    extra = np.flatnonzero(np.diff(action_states) == 0)
    if extra.size:
        raise drn.whole_line_error(
            "a state of a DTMC has exactly one action",
            body.line(action_idx[extra[0] + 1]),
            hint="use @type: MDP for states with several actions",
        )
    if header.nr_choices is not None and header.nr_choices not in (0, num_states):
        raise drn.whole_line_error(
            f"@nr_choices of a DTMC must equal @nr_states ({num_states})",
            header.nr_choices_line,
        )
    names = np.full(num_states, "", dtype=STR)
    names[action_states] = actions.names
    choice_lines = body.lines(state_idx)
    choice_lines[action_states] = body.lines(action_idx)
    trans_idx = np.flatnonzero(body.is_trans)
    return Choices(
        row_groups=np.arange(num_states + 1, dtype=np.int64),
        choice_of_trans=body.state_of(trans_idx),
        trans_idx=trans_idx,
        names=names,
        choice_lines=choice_lines,
        action_choice=action_states,
    )


def nondeterministic_choices(
    drn: DrnText,
    header: Header,
    body: Body,
    state_idx: np.ndarray,
    action_idx: np.ndarray,
    actions: Actions,
) -> Choices:
    """One choice per action line; each transition belongs to the action line above it."""
    num_states = int(state_idx.size)
    trans_idx = np.flatnonzero(body.is_trans)
    positions = np.arange(body.is_state.shape[0])
    last_action = np.maximum.accumulate(np.where(body.is_action, positions, -1))
    last_state = np.maximum.accumulate(np.where(body.is_state, positions, -1))
    orphan = trans_idx[last_action[trans_idx] < last_state[trans_idx]]
    if orphan.size:
        raise drn.whole_line_error(
            "a transition must follow an 'action' line",
            body.line(orphan[0]),
            hint="start each choice with 'action <name>' (or 'action __NOLABEL__')",
        )
    actions_per_state = np.bincount(body.state_of(action_idx), minlength=num_states)
    empty = np.flatnonzero(actions_per_state == 0)
    if empty.size:
        s = int(empty[0])
        raise drn.whole_line_error(
            f"state {s} has no actions",
            body.line(state_idx[s]),
            hint=f"give it a self-loop, as Storm does for deadlocks: "
            f"'action __NOLABEL__' and '{s} : 1'",
        )
    num_choices = int(action_idx.size)
    declared = header.nr_choices
    if declared and num_choices > declared:
        raise drn.whole_line_error(
            f"more choices than @nr_choices declares ({declared})",
            body.line(action_idx[declared]),
            hint=f"correct @nr_choices on line {header.nr_choices_line}",
        )
    if declared and num_choices < declared:
        raise drn.whole_line_error(
            f"@nr_choices declares {declared} choices, but the model has {num_choices}",
            header.nr_choices_line,
        )
    return Choices(
        row_groups=np.concatenate(([0], np.cumsum(actions_per_state))).astype(np.int64),
        choice_of_trans=(np.cumsum(body.is_action) - 1)[trans_idx],
        trans_idx=trans_idx,
        names=actions.names,
        choice_lines=body.lines(action_idx),
        action_choice=np.arange(num_choices, dtype=np.int64),
    )


def parse_transitions(
    drn: DrnText, header: Header, body: Body, choices: Choices, *, num_states: int
) -> sp.csr_matrix:
    """Parse all transition lines at once; check targets, values and per-choice sums."""
    trans_idx = choices.trans_idx
    num_choices = int(choices.row_groups[-1])
    lhs, sep, rhs = np.strings.partition(body.stripped[trans_idx], np.array(":", dtype=STR))
    missing = np.flatnonzero(sep != ":")
    if missing.size:
        raise drn.whole_line_error(
            "expected a transition '<target> : <probability>'",
            body.line(trans_idx[missing[0]]),
            hint="lines inside a state are 'action <name>' or '<target> : <probability>'",
        )
    lhs = np.strings.strip(lhs)
    rhs = np.strings.strip(rhs)

    def target_error(k: int, message: str) -> PosgmcError:
        ln = body.line(trans_idx[k])
        raw = drn.raw(ln)
        start = len(raw) - len(raw.lstrip())
        end = len(raw[: raw.index(":")].rstrip())
        return drn.error(message, ln, start + 1, end + 1)

    def value_error(k: int, problem: str) -> PosgmcError:
        ln = body.line(trans_idx[k])
        raw = drn.raw(ln)
        after = raw.index(":") + 1
        start = after + len(raw[after:]) - len(raw[after:].lstrip())
        return drn.error(f'the probability "{rhs[k]}" {problem}', ln, start + 1, len(raw) + 1)

    bad = np.flatnonzero(~np.strings.isdecimal(lhs))
    if bad.size:
        k = int(bad[0])
        raise target_error(k, f'the target state must be a state number, found "{lhs[k]}"')
    # more than 18 digits cannot be a state number (and would not fit int64)
    too_long = np.flatnonzero(np.strings.str_len(np.strings.lstrip(lhs, "0")) > 18)
    if too_long.size:
        k = int(too_long[0])
        raise target_error(
            k, f"target state {lhs[k]} does not exist (the model has states 0 to {num_states - 1})"
        )
    targets = lhs.astype(np.int64)
    out = np.flatnonzero(targets >= num_states)
    if out.size:
        k = int(out[0])
        raise target_error(
            k,
            f"target state {targets[k]} does not exist "
            f"(the model has states 0 to {num_states - 1})",
        )
    values = parse_values(rhs, placeholders=header.placeholders, on_error=value_error)
    negative = np.flatnonzero(values < 0)
    if negative.size:
        raise value_error(int(negative[0]), "is negative")
    above = np.flatnonzero(values > 1.0 + 1e-9)
    if above.size:
        raise value_error(int(above[0]), "is greater than 1")
    choice_of_trans = choices.choice_of_trans
    empty = np.flatnonzero(np.bincount(choice_of_trans, minlength=num_choices) == 0)
    if empty.size:
        raise drn.whole_line_error(
            "this choice has no transitions",
            int(choices.choice_lines[empty[0]]),
            hint="add transition lines '<target> : <probability>' below it",
        )
    sums = np.bincount(choice_of_trans, weights=values, minlength=num_choices)
    wrong = np.flatnonzero(np.abs(sums - 1.0) > 1e-9)
    if wrong.size:
        c = int(wrong[0])
        raise drn.whole_line_error(
            f"the probabilities of this choice sum to {float(sums[c])!r}, not 1",
            int(choices.choice_lines[c]),
            hint="the transition probabilities of every choice must sum to 1 (within 1e-9)",
        )
    keep = values > 0  # Storm keeps explicit zeros; they carry nothing, so they are dropped.
    # Repeated targets are summed (as Storm does) by make_model.
    return sp.csr_matrix(
        (values[keep], (choice_of_trans[keep], targets[keep])),
        shape=(num_choices, num_states),
    )
