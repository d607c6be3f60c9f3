"""Only the properties-file constants a property uses need a value (PRISM's
``UndefinedConstants``: ``getUndefinedConstantsUsedInProperties``); the model's always do."""

from __future__ import annotations

from pathlib import Path

from posgmc import api
from posgmc.errors import ConstantError

MODEL = (
    "dtmc\nmodule m\n  x : [0..2] init 0;\n  [] x<2 -> (x'=x+1);\n  [] x=2 -> true;\nendmodule\n"
)
PROPS = "const int k;\nconst double q;\nconst int j = k + 1;\nP=? [ F x=2 ];\nP=? [ F x=j ];\n"


def test_an_unused_undefined_constant_needs_no_value(tmp_path: Path) -> None:
    model, props = tmp_path / "m.pm", tmp_path / "m.pm.props"
    model.write_text(MODEL)
    props.write_text(PROPS)
    session = api.load(model)
    (p1, first), (p2, second) = api.iter_check(session, property_files=[props],
                                               built=api.build(session))
    assert first.value == 1.0  # uses neither k nor q
    # j is defined through k: k is needed (and only k: q is used nowhere)
    assert isinstance(second, ConstantError) and '"k"' in second.message
    assert '"q"' not in second.message
    (_, again), = [o for o in api.iter_check(api.load(model, constants={"k": 1}),
                                              property_files=[props],
                                              built=api.build(api.load(model, constants={"k": 1}),
                                                              allow_extra_constants=True))][1:]
    assert again.value == 1.0  # j = 2 is reached


def test_the_models_undefined_constants_are_always_needed() -> None:
    text = MODEL.replace("dtmc\n", "dtmc\nconst int unused;\n")
    try:
        api.build(api.load(text=text))
    except ConstantError as e:
        assert '"unused"' in e.message
    else:
        raise AssertionError("expected a ConstantError")
