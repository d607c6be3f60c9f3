"""PRISM explicit export: the files of tiny models checked line by line.

The expected texts follow PRISM-games' exporter (prism/src/io/PrismExplicitExporter.java at
prismmodelchecker/prism-games 5c9e3d2b): "# ..." headers, "S C T" sizes, "s j t p action" lines,
"s:p" owners in games, "- - s - o" initial states and target observations in POMDPs, labels as
'0="init" 1="deadlock" ...', reward files "base1.srew", "base2.srew", ... when there are several.
The models are those of tests/io/helpers.py; every number below can be read off their docstrings.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from posgmc.errors import UnsupportedError
from posgmc.io.prism_explicit import prism_explicit_texts, write_prism_explicit
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.syntax.ast import ModelType
from tests.io.helpers import tiny_dtmc, tiny_mdp, tiny_pomdp, tiny_posg, tiny_smg


def texts(model: ExplicitModel, **options: bool) -> dict[str, str]:
    return {p.name: t for p, t in prism_explicit_texts(model, "out/m", **options).items()}


def test_dtmc() -> None:
    files = texts(tiny_dtmc())
    assert list(files) == ["m.tra", "m.sta", "m.lab", "m.srew", "m.trew"]
    assert files["m.tra"].splitlines() == [
        "# Transitions (DTMC)",
        "3 5",
        "0 1 0.5",
        "0 2 0.5",
        "1 1 1",
        "2 0 0.25",
        "2 2 0.75",
    ]
    assert files["m.sta"].splitlines() == ["# States", "(x)", "0:(0)", "1:(1)", "2:(2)"]
    assert files["m.lab"].splitlines() == [
        "# Labels",
        '0="init" 1="deadlock" 2="goal"',
        "0: 0",
        "1: 2",
    ]
    assert files["m.srew"].splitlines() == [
        '# Reward structure "steps"',
        "# State rewards",
        "3 1",
        "0 1",
    ]
    assert files["m.trew"].splitlines() == [
        '# Reward structure "steps"',
        "# Transition rewards",
        "3 0",
    ]


def test_mdp_with_two_reward_structures() -> None:
    files = texts(tiny_mdp())
    assert list(files) == ["m.tra", "m.sta", "m.lab", "m1.srew", "m1.trew", "m2.srew", "m2.trew"]
    assert files["m.tra"].splitlines() == [
        "# Transitions (MDP)",
        "3 4 5",
        "0 0 1 0.3 a",
        "0 0 2 0.7 a",
        "0 1 0 1 b",
        "1 0 1 1",
        "2 0 2 1",
    ]
    assert files["m.sta"].splitlines() == ["# States", "(x,b)", "0:(0,0)", "1:(1,1)", "2:(-2,0)"]
    assert files["m.lab"].splitlines() == [
        "# Labels",
        '0="init" 1="deadlock" 2="goal" 3="two words"',
        "0: 0 3",
        "1: 2",
        "2: 1 3",
    ]
    assert files["m1.srew"].splitlines()[2:] == ["3 1", "1 1"]
    # The choice reward 2.5 of action a is repeated on both of its transitions, as PRISM does.
    assert files["m1.trew"].splitlines() == [
        '# Reward structure "r"',
        "# Transition rewards",
        "3 4 2",
        "0 0 1 2.5",
        "0 0 2 2.5",
    ]
    assert files["m2.srew"].splitlines()[2:] == ["3 0"]
    assert files["m2.trew"].splitlines()[2:] == ["3 4 1", "0 1 0 0.1"]


def test_pomdp() -> None:
    files = texts(tiny_pomdp())
    assert list(files) == ["m.tra", "m.lab", "m.obs"]
    assert files["m.tra"].splitlines() == [
        "# Transitions (POMDP)",
        "4 6 7 3",
        "- - 0 - 0",
        "0 0 1 0.5 1",
        "0 0 2 0.5 1",
        "1 0 3 1 2 l",
        "1 1 1 1 1 r",
        "2 0 2 1 1 l",
        "2 1 3 1 2 r",
        "3 0 3 1 2",
    ]
    assert files["m.obs"].splitlines() == ["# Observations", "(o)", "0:(0)", "1:(1)", "2:(2)"]


def test_smg() -> None:
    files = texts(tiny_smg())
    assert list(files) == ["m.tra", "m.lab"]
    assert files["m.tra"].splitlines() == [
        "# Transitions (SMG)",
        "3:2 4 5",
        "0:0 0 1 1 a",
        "0:0 1 2 1 b",
        "1:1 0 0 0.6666666666666666 c",
        "1:1 0 2 0.3333333333333333 c",
        "2:0 0 2 1",
    ]


def test_posg() -> None:
    files = texts(tiny_posg(same_observations=False))
    assert list(files) == ["m.tra", "m.lab", "m.pobs", "m.p1.obs", "m.p2.obs"]
    tra = files["m.tra"].splitlines()
    assert tra[0] == "# Transitions (SMG)"
    assert tra[1].startswith("# posgmc: a partially observable game")
    assert tra[2:] == texts(tiny_smg())["m.tra"].splitlines()[1:]
    assert files["m.pobs"].splitlines() == [
        "# Player observations",
        "(p1,p2)",
        "0:(0,0)",
        "1:(1,1)",
        "2:(1,2)",
    ]
    assert files["m.p1.obs"].splitlines() == ["# Observations", "()", "0:()", "1:()"]
    assert files["m.p2.obs"].splitlines()[-1] == "2:()"


def test_without_headers() -> None:
    files = texts(tiny_mdp(), headers=False)
    assert files["m.tra"].splitlines()[0] == "3 4 5"
    assert files["m.lab"].splitlines()[0] == '0="init" 1="deadlock" 2="goal" 3="two words"'
    assert files["m1.srew"].splitlines() == ["3 1", "1 1"]
    assert not any(t.startswith("#") for t in files.values())


def test_numbers_are_exact() -> None:
    model = make_model(ModelType.DTMC, [0, 1], [[1.0]], reward_models=())
    values = [0.1, 1 / 3, 1e-300, 123456.789]
    weights = np.array(values) / sum(values)
    chain = make_model(ModelType.DTMC, [0, 1, 2, 3, 4], np.tile(weights, (4, 1)))
    lines = texts(chain)["m.tra"].splitlines()[2:]
    assert [float(line.split()[2]) for line in lines[:4]] == weights.tolist()
    assert texts(model)["m.tra"].splitlines()[2] == "0 0 1"


def test_write_files(tmp_path: Path) -> None:
    paths = write_prism_explicit(tiny_mdp(), tmp_path / "model")
    assert [p.name for p in paths] == [
        "model.tra",
        "model.sta",
        "model.lab",
        "model1.srew",
        "model1.trew",
        "model2.srew",
        "model2.trew",
    ]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in paths)
    assert (tmp_path / "model.tra").read_text() == texts(tiny_mdp())["m.tra"]


def test_unwritable_label_writes_nothing(tmp_path: Path) -> None:
    bad = make_model(ModelType.DTMC, [0, 1], [[1.0]], labels={'a"b': [True]})
    with pytest.raises(UnsupportedError) as info:
        write_prism_explicit(bad, tmp_path / "model")
    assert "cannot be written in a PRISM .lab file" in info.value.message
    assert list(tmp_path.iterdir()) == []
