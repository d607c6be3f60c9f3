"""The adversary's deterministic memoryless strategies by SAT, and the numbers they give: on small
random POSGs, against brute force over every deterministic memoryless strategy of both players."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from posgmc import api
from posgmc.strategies.verify import StrategyChecker
from posgmc.syntax import parser
from posgmc.synthesis.adversaries import enumerate_adversaries, versus_adversaries
from posgmc.synthesis.options import SynthesisOptions
from posgmc.synthesis.search import synthesize
from tests.random_games import drawn_game
from tests.synthesis.helpers import POSMG, deterministic_strategies, labels_by_observation

PROP = '<<p0>> Pmax=? [ F "goal" ]'


@pytest.mark.parametrize("seed", [0, 1, 2, 3, 4, 5, 6, 7])
def test_brute_force_max_min_is_below_upper_bound(seed: int) -> None:
    model, _, _ = drawn_game(seed)
    coalition = api._resolver(model, False).coalition_of
    q = parser.parse_property(PROP).expr
    # player 0 sees one bit (ids 0/1), player 1 everything (the state number s)
    obs0 = model.observation_of(0)
    offered0 = labels_by_observation(model, 0, obs0.state_ids)[:2]
    keep0 = [i for i, row in enumerate(offered0) if row]
    own1 = np.flatnonzero(model.state_players == 1)
    offered1 = [
        [
            model.action_names[model.choice_actions[c]]
            for c in range(model.row_groups[s], model.row_groups[s + 1])
        ]
        for s in own1.tolist()
    ]
    d0 = list(
        deterministic_strategies(
            model, "p0", ("o",), np.array([[i] for i in keep0]), [offered0[i] for i in keep0]
        )
    )
    d1 = list(deterministic_strategies(model, "p1", ("s",), own1[:, None], offered1))
    maxmin = -1.0
    for f0 in d0:
        worst = min(StrategyChecker(model, {"p0": f0, "p1": f1}, coalition_of=coalition,
                                    scalar=api._scalar).check(q, text=PROP).vs_fss_adversary.value
                    for f1 in d1)
        maxmin = max(maxmin, worst)
    enum = enumerate_adversaries(model, 1, limit=10_000)
    assert enum.exhaustive and 1 <= len(enum.strategies) <= len(d1)
    result = synthesize(
        model,
        q,
        player=0,
        coalition_of=coalition,
        scalar=api._scalar,
        options=SynthesisOptions(memory=(1,), restarts=1, iterations=15, timeout=30),
    )
    vs, ub, evaluated, _ = versus_adversaries(
        model,
        q,
        result.strategy,
        enum.strategies,
        maximize=True,
        coalition_of=coalition,
        scalar=api._scalar,
    )
    assert evaluated == len(enum.strategies)
    assert maxmin <= ub.upper + 1e-6
    assert result.guaranteed.lower <= vs.upper + 1e-6  # guaranteed <= value vs every adversary


def test_enumeration_counts_the_classes_that_matter() -> None:
    """test-game: the opponent moves once, odd or even (2 classes, by hand from the DRN);
    dice-and-coin2: 4 classes (pinned from this enumeration, exhaustive by the solver)."""
    for name, count in (("test-game", 2), ("dice-and-coin2", 4)):
        model = api.build(api.load(POSMG / name / "sketch.templ")).model
        enum = enumerate_adversaries(model, 1)
        assert enum.exhaustive and len(enum.strategies) == count


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_adversaries_with_memory_include_the_memoryless_ones(seed: int) -> None:
    """Two-node adversaries (k□ = 2) contain every memoryless behaviour (a node that never
    changes), so against a fixed defence the worst of them is at least as bad as the worst
    memoryless one; every enumerated strategy is distinct on the reachable part (no two give the
    same product); and enumeration is exhaustive on these small games."""
    model, _, _ = drawn_game(seed)
    coalition = api._resolver(model, False).coalition_of
    q = parser.parse_property(PROP).expr
    one = enumerate_adversaries(model, 1, limit=10_000)
    two = enumerate_adversaries(model, 1, memory=2, limit=10_000)
    assert one.exhaustive and two.exhaustive
    assert len(two.strategies) >= len(one.strategies)
    assert all(f.memory_size == 2 for f in two.strategies)
    result = synthesize(
        model,
        q,
        player=0,
        coalition_of=coalition,
        scalar=api._scalar,
        options=SynthesisOptions(memory=(1,), restarts=1, iterations=10, timeout=30),
    )
    vs1, _, _, _ = versus_adversaries(model, q, result.strategy, one.strategies, maximize=True,
                                      coalition_of=coalition, scalar=api._scalar)
    vs2, _, _, worst = versus_adversaries(model, q, result.strategy, two.strategies, maximize=True,
                                          coalition_of=coalition, scalar=api._scalar)
    assert vs2.value <= vs1.value + 1e-9
    assert worst is not None and worst.memory_size == 2
    # still above what the defence guarantees against the omniscient adversary
    assert result.guaranteed.lower <= vs2.upper + 1e-6


_UNREACHABLE_ADVERSARY = """posg
player d
  [go], [stay]
  observables s endobservables
endplayer
player a
  [hit]
endplayer
module m
  s : [0..3] init 0;
  [go] s=0 -> 0.5:(s'=1) + 0.5:(s'=2);
  [stay] s=0 -> (s'=0);
  [hit] s=3 -> (s'=2);
endmodule
label "goal" = s=1;
"""


def test_an_adversary_that_never_decides_has_nothing_to_enumerate() -> None:
    """The adversary's only state (s=3) is unreachable: no strategy to enumerate (this crashed
    building a strategy over no observations), and synthesis still answers: going reaches the
    goal with probability 1/2 (by hand), and no adversary can change that."""
    from posgmc import api
    from posgmc.synthesis.adversaries import enumerate_adversaries

    session = api.load(text=_UNREACHABLE_ADVERSARY)
    model = api.build(session).model
    assert model.num_states == 3  # s = 0, 1, 2 (s=3 is never reached)
    assert enumerate_adversaries(model, 1).strategies == ()
    r = api.synthesize(session, '<<d>> Pmax=? [ F "goal" ]', memory=1, timeout=5, seed=0)
    assert r.guaranteed is not None
    assert r.guaranteed.lower <= 0.5 <= r.guaranteed.upper


def test_many_memory_nodes_stop_at_the_deadline_and_fit_in_memory(
    monkeypatch: pytest.MonkeyPatch
) -> None:
    """--memory attacker=500: the encoding is linear in k·Z·(A + k) and stops at the deadline
    (before: cubic symmetry clauses, over 100 s and 5.3 GB); an encoding that cannot fit in the
    memory available enumerates nothing instead of failing."""
    import time

    from posgmc.synthesis import adversaries

    model = api.build(api.load(ROOT_MODELS / "rover.posg")).model
    attacker = model.player_names.index("attacker")
    gone = enumerate_adversaries(model, attacker, memory=500, deadline=time.perf_counter())
    assert gone.strategies == () and not gone.exhaustive
    found = enumerate_adversaries(model, attacker, memory=12, limit=3)
    assert len(found.strategies) == 3 and all(f.memory_size == 12 for f in found.strategies)
    monkeypatch.setattr(adversaries, "check_allocation", _refuse)
    assert enumerate_adversaries(model, attacker, memory=2).strategies == ()


def _refuse(num_bytes: float, what: str, **_: object) -> None:
    from posgmc.errors import LimitError

    raise LimitError(f"{what} would need {num_bytes} bytes")


ROOT_MODELS = Path(__file__).resolve().parents[2] / "models"
