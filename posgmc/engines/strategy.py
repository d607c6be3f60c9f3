"""What a computed strategy does to the model: the dtmc a memoryless deterministic strategy
induces (to re-check a strategy's value, or export the chain it fixes)."""

from __future__ import annotations

import numpy as np

from posgmc.errors import PosgmcError
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.model.types import ModelType

__all__ = ["induced_chain"]


def induced_chain(model: ExplicitModel, strategy: np.ndarray) -> ExplicitModel:
    """The dtmc a memoryless deterministic strategy induces.

    Args:
        model: any model type.
        strategy: int64[S], a global choice index per state; -1 takes the state's first choice.

    Returns:
        A dtmc with the same states, labels, valuations and initial states; its reward models carry
        the chosen choices' rewards (state + action reward) as choice rewards.

    Raises:
        PosgmcError: a choice does not belong to its state.
    """
    S = model.num_states
    st = np.asarray(strategy, dtype=np.int64)
    if st.shape != (S,):
        raise PosgmcError(f"a strategy needs one entry per state ({S}), got {st.shape}")
    rows = np.where(st < 0, model.row_groups[:-1], st)
    owner_ok = (rows >= model.row_groups[:-1]) & (rows < model.row_groups[1:])
    if not owner_ok.all():
        s = int(np.flatnonzero(~owner_ok)[0])
        raise PosgmcError(f"strategy: choice {int(rows[s])} does not belong to state {s}")
    from posgmc.model.explicit import RewardModel

    rms = tuple(
        RewardModel(name=rm.name, state=None, choice=rm.choice_rewards(model.row_groups)[rows])
        for rm in model.reward_models
    )
    return make_model(
        ModelType.DTMC,
        np.arange(S + 1, dtype=np.int64),
        model.transitions[rows],
        initial_states=model.initial_states,
        choice_actions=model.choice_actions[rows],
        action_names=model.action_names,
        labels=dict(model.labels),
        reward_models=rms,
        variable_names=model.variable_names,
        state_values=model.state_values,
        deadlocks=model.deadlocks,
        boolean_variables=model.boolean_variables,
    )
