"""``import posgmc`` gives the stages, records and errors at top level (the library API)."""

from __future__ import annotations

from pathlib import Path

import pytest

import posgmc

ROOT = Path(__file__).resolve().parents[1]


def test_every_name_in_all_resolves() -> None:
    for name in posgmc.__all__:
        assert getattr(posgmc, name) is not None, name
    with pytest.raises(AttributeError):
        posgmc.no_such_thing  # noqa: B018


def test_the_stages_at_top_level_answer_a_property() -> None:
    """models/rover.smg: 0.9876561794 (tests/test_models.py)."""
    report = posgmc.check(posgmc.load(ROOT / "models" / "rover.smg"),
                          properties=['<<rover>> Pmax=? [ !"crash" U "goal" ]'])
    result = report.results[0]
    assert isinstance(result, posgmc.PropertyResult)
    assert result.lower <= 0.9876561794 + 1e-9 and 0.9876561794 - 1e-9 <= result.upper
    built = posgmc.build(posgmc.load(ROOT / "models" / "rover.smg"))
    assert isinstance(built, posgmc.BuiltModel) and built.model.num_states == 60
    with pytest.raises(posgmc.PosgmcError):
        posgmc.build(
            posgmc.load(text="dtmc\nmodule m x : [0..1] init 0; [] x=0 -> (y'=1); endmodule\n")
        )


def test_the_package_is_typed() -> None:
    assert (Path(posgmc.__file__).parent / "py.typed").exists()
