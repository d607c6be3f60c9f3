"""The product of a model with strategies: refused with the sizes when it cannot fit in memory."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from posgmc import api, resources
from posgmc.errors import LimitError
from posgmc.strategies.binding import bind
from posgmc.strategies.files import strategy_from_json
from posgmc.strategies.product import strategy_product

ROOT = Path(__file__).resolve().parents[2]


def test_a_product_that_cannot_fit_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    doc = json.loads((ROOT / "models" / "rover" / "forward.fss.json").read_text())
    doc["memory_size"] = 1_000_000  # nodes no rule names still lay out the product
    model = api.build(api.load(ROOT / "models" / "rover.posg")).model
    assert model.num_states == 60
    b = bind(model, strategy_from_json(doc, file="f.json"))
    monkeypatch.setattr(resources, "available_bytes", lambda: 1 << 30)
    with pytest.raises(LimitError) as info:
        strategy_product(model, [b])
    assert "the product of the model (60 states) with the strategies' memory (1000000 = " \
        "1,000,000 joint memory nodes) would need" in info.value.message
    assert info.value.hint == "use strategies with fewer memory nodes, or a smaller model"
