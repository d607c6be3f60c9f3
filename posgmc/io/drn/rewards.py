"""The reward models of a DRN model, from the reward lists of its state and action lines.

A state line's list gives state rewards, an action line's list the rewards of its choice. As in
Storm, the number of reward models is the longest list; reward model i is named by the i-th name
of ``@reward_models`` (an empty name is an unnamed reward model; a missing one is ``rew<i>``).
Every list has one value per reward model, or is empty (``[]``: all zero).
"""

from __future__ import annotations

import numpy as np

from posgmc.errors import PosgmcError
from posgmc.io._text import parse_values
from posgmc.io.drn.body import Actions, States, partition
from posgmc.io.drn.header import Header
from posgmc.io.drn.lines import parse_action_line, parse_state_line
from posgmc.io.drn.source import DrnText
from posgmc.io.drn.transitions import Choices
from posgmc.model.explicit import RewardModel
from posgmc.syntax.ast import ModelType

__all__ = ["parse_reward_models"]


def parse_reward_models(
    drn: DrnText,
    header: Header,
    model_type: ModelType,
    states: States,
    actions: Actions,
    choices: Choices,
) -> tuple[RewardModel, ...]:
    """Reward models from the lists on state lines (state rewards) and action lines."""
    num_states = states.lines.shape[0]
    num_choices = int(choices.row_groups[-1])
    # One row per reward list, in file order.
    with_state, with_action = states.has_rewards, actions.has_rewards
    on_state = np.repeat([True, False], [int(with_state.sum()), int(with_action.sum())])
    owner = np.concatenate((np.flatnonzero(with_state), choices.action_choice[with_action]))
    lines = np.concatenate((states.lines[with_state], actions.lines[with_action]))
    inner = np.concatenate((states.rewards[with_state], actions.rewards[with_action]))
    order = np.argsort(lines, kind="stable")
    on_state, owner, lines, inner = on_state[order], owner[order], lines[order], inner[order]
    blank = np.strings.str_len(np.strings.strip(inner)) == 0
    count = np.where(blank, 0, np.strings.count(inner, ",") + 1)
    num_rewards = int(count.max()) if count.size else 0
    if num_rewards == 0:
        return ()

    def line_parse(k: int) -> tuple[list[tuple[str, int]], int]:
        """List k parsed by the per-line parser: its (text, column) values and its column."""
        line = int(lines[k])
        if on_state[k]:
            st = parse_state_line(drn, line, int(owner[k]), model_type)
            return st.rewards or [], st.rewards_column
        action = parse_action_line(drn, line)
        return action.rewards or [], action.rewards_column

    columns = []
    rest = inner
    for _ in range(num_rewards):
        head, _sep, rest = partition(rest, ",")
        columns.append(np.strings.strip(head))
    texts = np.stack(columns, axis=1)  # [lists, num_rewards]
    present = np.arange(num_rewards)[None, :] < count[:, None]
    empty = np.flatnonzero((present & (np.strings.str_len(texts) == 0)).any(axis=1))
    if empty.size:
        line_parse(int(empty[0]))  # raises "empty reward value" with its position
    wrong = np.flatnonzero((count != 0) & (count != num_rewards))
    if wrong.size:
        k = int(wrong[0])
        raise drn.error(
            f"expected {num_rewards} reward values (one per reward model), "
            f"found {int(count[k])}",
            int(lines[k]),
            line_parse(k)[1],
            hint="every reward list has one value per reward model, or is empty ([])",
        )
    full = np.flatnonzero(count == num_rewards)

    def reward_error(k: int, problem: str) -> PosgmcError:
        row, r = int(full[k // num_rewards]), k % num_rewards
        text, column = line_parse(row)[0][r]
        return drn.error(
            f'the reward "{text}" {problem}', int(lines[row]), column, column + len(text)
        )

    values = parse_values(
        texts[full].ravel(), placeholders=header.placeholders, on_error=reward_error
    ).reshape(full.size, num_rewards)
    state_rewards = np.zeros((num_rewards, num_states))
    choice_rewards = np.zeros((num_rewards, num_choices))
    full_on_state = on_state[full]
    state_rewards[:, owner[full][full_on_state]] = values[full_on_state].T
    choice_rewards[:, owner[full][~full_on_state]] = values[~full_on_state].T
    result = []
    for r in range(num_rewards):
        # Storm: the i-th name of @reward_models, or "rew<i>" when there are too few names.
        name = header.reward_names[r] if r < len(header.reward_names) else f"rew{r}"
        result.append(
            RewardModel(
                name or None,
                state_rewards[r] if np.any(state_rewards[r]) else None,
                choice_rewards[r] if np.any(choice_rewards[r]) else None,
            )
        )
    return tuple(result)
