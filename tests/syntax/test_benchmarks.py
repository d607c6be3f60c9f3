"""Every PRISM-language model and property file among the vendored benchmarks parses.

DRN files (PAYNT's ``sketch.templ`` exported by Storm/PRISM) are skipped: they are explicit models
read by ``posgmc.io``, not PRISM text. Counts and ``// RESULT`` values below are read off the
files themselves (``benchmarks/smg/...`` are PRISM-games regression tests).
"""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import pytest

from posgmc.syntax.ast import (
    DoubleLit,
    Ident,
    ModelType,
    ProbQuery,
    RewardKind,
    RewardQuery,
)
from posgmc.syntax.parser import load_model, load_properties
from tests.conftest import BENCHMARKS

MODEL_SUFFIXES = (".prism", ".nm", ".smg")


def _is_drn(path: Path) -> bool:
    head = path.read_text(encoding="utf-8", errors="replace")[:4000]
    return head.lstrip().startswith("// Exported") or "@type:" in head


def _model_files() -> list[Path]:
    files = [
        p
        for p in sorted(BENCHMARKS.rglob("*"))
        if p.is_file() and (p.suffix in MODEL_SUFFIXES or p.name == "sketch.templ")
    ]
    return [p for p in files if not _is_drn(p)]


def _props_files() -> list[Path]:
    return sorted(p for p in BENCHMARKS.rglob("*.props") if p.is_file())


def _ids(paths: list[Path]) -> list[str]:
    return [str(p.relative_to(BENCHMARKS)) for p in paths]


MODELS = _model_files()
PROPS = _props_files()


@pytest.mark.parametrize("path", MODELS, ids=_ids(MODELS))
def test_model_parses(benchmarks: Path, path: Path) -> None:
    model = load_model(path)
    assert model.file == str(path)
    assert model.modules, "every benchmark model has at least one module"
    assert all(m.span.file == str(path) for m in model.modules)


@pytest.mark.parametrize("path", PROPS, ids=_ids(PROPS))
def test_properties_parse(benchmarks: Path, path: Path) -> None:
    props = load_properties(path)
    assert props.properties, "every benchmark property file has a property"
    for prop in props.properties:
        assert prop.text, "the source text of each property is kept"
        assert prop.span.file == str(path)


def test_benchmark_file_counts(benchmarks: Path) -> None:
    # At least what the benchmark set held when these tests were written (58 PRISM model files;
    # the other sketch.templ files are DRN; 50 property files), so that a broken DRN detection
    # or file walk cannot silently test nothing.
    assert len(MODELS) >= 58
    assert len(PROPS) >= 50


def test_dice_and_coin_rew_is_valid_prism_syntax(benchmarks: Path) -> None:
    # Marked "NEFUNGUJE" (does not work) upstream; Storm fails at its `rewards` block. The
    # syntax is fine for PRISM-games: `end` is not a PRISM keyword (PrismParser.jj's token list),
    # so `module end ... endmodule` is an ordinary module. What fails is the reward item
    # `gambler_won : 100;`: `gambler_won` is defined nowhere (the formula is `gambler_win`), an
    # undefined identifier that Storm reports while parsing and posgmc's semantic pass reports.
    model = load_model(benchmarks / "posmg/prism-models/dice-and-coin_rew.prism")
    assert model.model_type is ModelType.SMG
    assert [m.name for m in model.modules] == ["cashier", "gambler", "end"]
    (rewards,) = model.rewards
    (item,) = rewards.items
    assert item.guard == Ident("gambler_won")
    assert item.span.line == 68


def test_drone_model_uses_r_as_a_constant(benchmarks: Path) -> None:
    # `const int R = 1;` (pomdp/drone-4-1): R is a property keyword but an ordinary name in models.
    model = load_model(benchmarks / "pomdp/drone-4-1/sketch.templ")
    assert model.model_type is ModelType.POMDP
    assert "R" in [c.name for c in model.constants]
    (obs,) = [o for o in model.observables if not hasattr(o, "name")]
    assert [v.name for v in obs.variables] == ["start", "dx", "dy", "turn"]


def test_smg_example_results(benchmarks: Path) -> None:
    props = load_properties(benchmarks / "smg/smg_example/smg_example.prism.props")
    assert [c.name for c in props.constants] == ["k"]
    assert len(props.properties) == 14
    assert all(len(p.expected) >= 1 for p in props.properties)
    third = props.properties[2]
    assert third.text == "<<1>> Pmax=? [ F<=k c=2 ]"
    assert [(e.constants, e.text) for e in third.expected] == [
        ((("k", "0"),), "0.0"),
        ((("k", "1"),), "0.85"),
        ((("k", "2"),), "0.85"),
        ((("k", "3"),), "0.9775"),
        ((("k", "4"),), "0.9775"),
        ((("k", "5"),), "0.996625"),
    ]
    assert (third.expected[3].span.line, third.expected[3].span.column) == (12, 4)
    assert props.properties[0].expected[0].text == "true"
    last = props.properties[-1]
    assert isinstance(last.expr, ProbQuery)
    assert last.expr.coalition is not None and last.expr.coalition.all_players


def test_coins_reward_objectives(benchmarks: Path) -> None:
    props = load_properties(benchmarks / "smg/coins/coins.prism.props")
    assert len(props.properties) == 26
    kinds = [
        p.expr.objective.kind for p in props.properties if isinstance(p.expr, RewardQuery)
    ]
    assert kinds == (
        [RewardKind.REACH] * 6
        + [RewardKind.REACH_ZERO] * 4
        + [RewardKind.REACH_CUMULATIVE] * 4
        + [RewardKind.INSTANTANEOUS] * 2
        + [RewardKind.CUMULATIVE] * 4
    )
    assert [e.text for e in props.properties[6].expected] == ["Infinity"]


def test_robot_reward_results_keep_first_word(benchmarks: Path) -> None:
    # `// RESULT: 1.2  //  = 1+(...)`: PRISM's pattern takes the first word after the colon.
    props = load_properties(benchmarks / "smg/robot/robot.prism.rewards.cosafe.props")
    assert len(props.properties) == 12
    texts = [p.expected[0].text for p in props.properties]
    assert texts[0] == "1.2"
    assert texts[6] == "19/15"
    assert texts[-3:] == ["Error:co-safe"] * 3
    first = props.properties[0].expr
    assert isinstance(first, RewardQuery) and first.objective.kind is RewardKind.LTL
    # `(F "goal2")`, `F "goal2"` are reachability rewards; `s!=3 U "goal2"` is co-safe LTL
    assert [
        p.expr.objective.kind
        for p in props.properties[6:9]
        if isinstance(p.expr, RewardQuery)
    ] == [RewardKind.REACH, RewardKind.REACH, RewardKind.LTL]


def test_interval_result_and_named_property(benchmarks: Path) -> None:
    grid = load_properties(benchmarks / "pomdp/prism-3x3grid/3x3grid.prism.props")
    (prop,) = grid.properties
    assert [e.text for e in prop.expected] == ["[2.8496094277343733,2.8750000000000004]"]
    crypt = load_properties(benchmarks / "pomdp/crypt-4/sketch.props")
    (named,) = crypt.properties  # the other one is commented out
    assert named.name == "maximum"
    assert named.text == '"maximum": Pmax=? [ F correct=1 ]'


def test_investor_result_with_two_constants(benchmarks: Path) -> None:
    props = load_properties(benchmarks / "smg/investor/investor.prism.props")
    (prop,) = props.properties
    (expected,) = prop.expected
    assert expected.constants == (("vmax", "5"), ("vinit", "2"))
    assert expected.text == "2.365893"
    assert isinstance(prop.expr, RewardQuery)
    assert prop.expr.objective.kind is RewardKind.REACH_CUMULATIVE


def test_mdsm_scaled_query(benchmarks: Path) -> None:
    props = load_properties(benchmarks / "smg/mdsm2304/mdsm2304.props")
    assert len(props.properties) == 2
    second = props.properties[1].expr
    # (1/2) * <<p1,p2>> R{"value12"}max=? [F time=max_time]
    assert second.left.right.value == 2  # type: ignore[attr-defined]
    query = second.right  # type: ignore[attr-defined]
    assert isinstance(query, RewardQuery)
    assert query.reward == "value12"
    assert query.objective.kind is RewardKind.REACH
    assert query.objective.target.left == Ident("time")  # type: ignore[union-attr]


def test_semicolon_terminated_without_newline(benchmarks: Path) -> None:
    # `Pmax=?["notbad" U "goal"];` with no final newline (pomdp/drone-4-1/sketch.props)
    props = load_properties(benchmarks / "pomdp/drone-4-1/sketch.props")
    assert len(props.properties) == 1


def test_exact_double_literals_in_benchmark(benchmarks: Path) -> None:
    model = load_model(benchmarks / "smg/smg_example/smg_example.prism")
    command = model.modules[1].commands[0]  # type: ignore[union-attr]
    assert command.updates[0].probability == DoubleLit(Fraction(85, 100))
