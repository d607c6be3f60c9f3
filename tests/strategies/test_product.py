"""The product of a model with strategies: laid out over the memory nodes a strategy can enter
only, and refused with the sizes when it cannot fit in memory."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from posgmc import api, resources
from posgmc.errors import LimitError
from posgmc.strategies.binding import bind
from posgmc.strategies.files import strategy_from_json
from posgmc.strategies.product import strategy_product

ROOT = Path(__file__).resolve().parents[2]
FORWARD = ROOT / "models" / "rover" / "forward.fss.json"


def _rover():  # type: ignore[no-untyped-def]
    model = api.build(api.load(ROOT / "models" / "rover.posg")).model
    assert model.num_states == 60  # the rover as shipped
    return model


def test_nodes_no_rule_enters_cost_nothing() -> None:
    """memory_size 10^6 with the rules of node 0 only: the product is that of the memoryless
    strategy (node 0 never moves), with the same states and memory 0 everywhere."""
    model = _rover()
    doc = json.loads(FORWARD.read_text())
    small = strategy_product(model, [bind(model, strategy_from_json(doc))])
    doc["memory_size"] = 1_000_000
    big = strategy_product(model, [bind(model, strategy_from_json(doc))])
    assert big.model.num_states == small.model.num_states
    assert np.array_equal(big.state_of, small.state_of) and not big.memory_of.any()


def test_a_product_that_cannot_fit_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    k = 20_000  # every node entered: node n moves to n + 1 on every rule
    rules = [{"memory": n, "observation": {"x": x},
              "action": {("done" if x in (0, 6) else "fwd"): 1.0},
              "update": {("done" if x in (0, 6) else "fwd"): {str((n + 1) % k): 1.0}}}
             for n in range(k) for x in range(7)]
    doc = {**json.loads(FORWARD.read_text()), "memory_size": k, "rules": rules}
    model = _rover()
    b = bind(model, strategy_from_json(doc, file="f.json"))
    monkeypatch.setattr(resources, "available_bytes", lambda: 1 << 20)
    with pytest.raises(LimitError) as info:
        strategy_product(model, [b])
    assert "the product of the model (60 states) with the strategies' memory (20000 = " \
        "20,000 joint memory nodes) would need" in info.value.message
    assert info.value.hint == "use strategies with fewer memory nodes, or a smaller model"
