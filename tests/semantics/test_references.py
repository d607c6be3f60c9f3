"""References to other properties by name (PRISM's ``PropertiesFile.findAllPropRefs``)."""

from __future__ import annotations

from pathlib import Path

from posgmc import api
from posgmc.errors import SemanticError

# A die-like chain: s=0 goes to d=1..3 with 1/3 each. By hand: P(F d=k) = 1/3 for k = 1, 2, 3.
MODEL = """
dtmc
module m
  d : [0..3] init 0;
  [] d=0 -> 1/3:(d'=1) + 1/3:(d'=2) + 1/3:(d'=3);
  [] d>0 -> true;
endmodule
label "two" = d=2;
"""

PROPS = """
const int k = 3;
// the shape of PRISM's propertyrefs.pm.props: each refers to the next, 1/3 + 1/3 + 1/3
"one": P=? [ F d=1 ] + "three";
"three": P=? [ F d=k ] + "two2";
"two2": P=? [ F d=2 ];
"two": P=? [ F "two" ];
"self": 1 - "self";
"""


def test_references_resolve_to_the_named_properties(tmp_path: Path) -> None:
    model, props = tmp_path / "m.pm", tmp_path / "m.pm.props"
    model.write_text(MODEL)
    props.write_text(PROPS)
    session = api.load(model)
    outcomes = dict(
        (p.name, o)
        for p, o in api.iter_check(session, property_files=[props], built=api.build(session))
    )
    assert abs(outcomes["one"].value - 1.0) < 1e-6
    assert abs(outcomes["three"].value - 2 / 3) < 1e-6
    # a label of the same name wins over the property: "two" is the label d=2 inside it
    assert abs(outcomes["two"].value - 1 / 3) < 1e-6
    err = outcomes["self"]
    assert (
        isinstance(err, SemanticError)
        and 'property "self" -> "self" refers to itself' in err.message
    )
