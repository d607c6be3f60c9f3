"""The Python API validates its arguments and raises documented PosgmcError subclasses (issue
#13)."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from posgmc import api
from posgmc.cli import main
from posgmc.errors import InputError

ROVER = str(Path(__file__).resolve().parents[1] / "models" / "rover.smg")


@pytest.mark.parametrize(
    ("call", "words"),
    [
        (lambda: api.load(None), "give the model's path or its text"),
        (lambda: api.load(123), "path must be a file path, got int"),
        (lambda: api.load(text=b"dtmc"), "text must be a string, got bytes"),
        (lambda: api.load(ROVER, constants=["N=1"]), "constants must be a mapping"),
        (lambda: api.check(ROVER), "expected a Session from api.load, got str"),
        (
            lambda: api.check(api.load(ROVER), options={"precision": 1}),
            "options must be a CheckOptions",
        ),
        (
            lambda: api.check(api.load(ROVER), properties=[1]),
            "properties must be a string or a list",
        ),
        (lambda: api.build(api.load(ROVER), options=None), "options must be a BuildOptions"),
    ],
)
def test_bad_arguments_raise_input_errors(call, words: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InputError, match=words):
        call()


def test_a_single_string_is_one_file_not_its_characters() -> None:
    errors = api.lint(ROVER, property_files="nope.props")
    assert [e.message for e in errors] == ["no such file: nope.props"]


def test_none_means_no_properties() -> None:
    report = api.check(api.load(ROVER), properties=None, property_files=None)
    assert report.results == ()


def test_a_single_property_text() -> None:
    report = api.check(api.load(ROVER), properties='<<rover>> Pmax=? [ F "goal" ]')
    assert len(report.results) == 1


def test_dash_reads_the_model_from_standard_input() -> None:
    text = Path(ROVER).read_text()
    r = CliRunner().invoke(main, ["build", "-", "--json"], input=text)
    assert r.exit_code == 0, r.output
    assert '"states": 60' in r.output


def test_check_takes_a_compiled_model_and_validates_it() -> None:
    from posgmc.model.explicit import ExplicitModel, ModelInvariantError

    model = api.build(api.load(ROVER)).model
    report = api.check(model, properties=['<<rover>> Pmax=? [ F "goal" ]'])
    assert report.model is model and report.results[0].lower <= 0.9876561794
    broken = ExplicitModel(**{**{f: getattr(model, f) for f in (
        "model_type", "row_groups", "transitions", "choice_actions", "action_names",
        "state_players", "player_names", "labels", "variable_names", "state_values", "deadlocks",
    )}, "initial_states": model.initial_states[::-1].copy() if model.initial_states.size > 1
        else model.initial_states.repeat(2)})
    with pytest.raises(ModelInvariantError, match="sorted and distinct"):
        api.check(broken, properties=['<<rover>> Pmax=? [ F "goal" ]'])


def test_with_constants_keeps_the_parse_and_checks_its_argument() -> None:
    session = api.load(text="dtmc const int N; module m x:[0..N] init 0; [] x<N -> (x'=x+1); "
                            "[] x=N -> true; endmodule")
    assert session.with_constants(N=3).constants == {"N": 3}
    assert session.with_constants({"N": 2}).syntax is session.syntax  # parsed once
    assert api.build(session.with_constants(N=3)).model.num_states == 4
    with pytest.raises(InputError, match="constants must be a mapping"):
        session.with_constants(["N=3"])  # type: ignore[arg-type]


def test_outcomes_are_typed() -> None:
    report = api.check(api.load(ROVER), properties=['Pmax=? [ F "nowhere" ]'])
    (outcome,) = report.outcomes
    assert isinstance(outcome, api.PropertyError)
    text, error = outcome  # still a pair
    assert text == outcome.property and error is outcome.error


POSG = str(Path(__file__).resolve().parents[1] / "models" / "rover.posg")
FORWARD = str(Path(__file__).resolve().parents[1] / "models" / "rover" / "forward.fss.json")
REACH = '<<rover>> Pmax=? [ F "goal" ]'


def _posg():  # type: ignore[no-untyped-def]
    return api.load(POSG)


@pytest.mark.parametrize(
    ("call", "words"),
    [
        # each raised a raw TypeError, AttributeError or ValueError before
        (lambda: api.check(_posg(), properties=[REACH], strategies={"rover": None}),
         r"strategies\['rover'\] must be a FiniteStateStrategy or a strategy file's path, got "
         "NoneType"),
        (lambda: api.check(_posg(), properties=[REACH], strategies={"rover": 5}),
         r"strategies\['rover'\] must be .* got int"),
        (lambda: api.simulate(_posg(), REACH, strategies={"rover": FORWARD.encode()}),
         r"strategies\['rover'\] must be .* got bytes"),
        (lambda: api.simulate(_posg(), REACH, strategies=[api.load_strategy(FORWARD)]),
         "strategies must map player names to strategies, got list"),
        (lambda: api.check(_posg(), properties=[REACH], synthesis=5),
         "synthesis must be a SynthesisOptions, got int"),
        (lambda: api.load_strategy(None), "path must be a file path .* got NoneType"),
        (lambda: api.load_strategy(5), "path must be a file path .* got int"),
        (lambda: api.load_strategy(FORWARD.encode()), "path must be a file path .* got bytes"),
        (lambda: api.load_strategy({}), "path must be a file path .* got dict"),
        (lambda: api.save_strategy(None, "s.json"), "strategy must be a FiniteStateStrategy"),
        (lambda: api.synthesize(_posg(), REACH, memory=(2, 1)),
         r"memory must ascend without repeats .* got \(2, 1\)"),
        (lambda: api.synthesize(_posg(), REACH, memory=1.5),
         "memory must be a memory size .* got 1.5"),
        (lambda: api.synthesize(_posg(), REACH, memory={"rover": None}),
         r"memory\['rover'\] must be a memory size .* got None"),
        (lambda: api.synthesize(_posg(), REACH, memory=10**20),
         "memory must be ints from 1 to 10000"),
        (lambda: api.synthesize(_posg(), REACH, effort=0),
         "effort must be a positive finite number, got 0"),
        (lambda: api.synthesize(_posg(), REACH, effort=float("inf")),
         "effort must be a positive finite number, got inf"),
        (lambda: api.synthesize(_posg(), REACH, timeout="5"),
         "timeout must be a positive finite number of seconds or None, got '5'"),
        (lambda: api.synthesize(_posg(), REACH, timeout=float("nan")),
         "timeout must be a positive finite number of seconds or None, got nan"),
        (lambda: api.synthesize(_posg(), REACH, seed=-1), "seed must be an int of at least 0"),
        (lambda: api.synthesize(_posg(), REACH, seed="a"), "seed must be an int of at least 0"),
        (lambda: api.synthesize(_posg(), REACH, jobs="2"), "jobs must be an int of at least 1"),
        (lambda: api.synthesize(_posg(), REACH, adversaries="a"),
         "adversaries must be an int of at least 0"),
        (lambda: api.simulate(_posg(), REACH, strategies={"rover": FORWARD}, seed=-1),
         "seed must be an int of at least 0"),
        (lambda: api.simulate(_posg(), REACH, strategies={"rover": FORWARD}, opponent="worst"),
         "opponent must be 'uniform' or 'best'"),
    ],
)
def test_strategy_and_synthesis_arguments_raise_input_errors(call, words: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InputError, match=words):
        call()


@pytest.mark.parametrize("path", [None, 5])
def test_save_strategy_writes_no_file_named_after_a_bad_path(
        path: object, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``save_strategy(fss, None)`` wrote a file named ``None``."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(InputError, match="path must be a file path"):
        api.save_strategy(api.load_strategy(FORWARD), path)  # type: ignore[arg-type]
    assert list(tmp_path.iterdir()) == []


def test_simulate_refuses_runs_that_cannot_fit_before_allocating() -> None:
    """10^11 runs: numpy's MemoryError (745 GiB) before; 10^9 were killed by the OOM killer."""
    from posgmc.errors import LimitError

    with pytest.raises(LimitError, match=r"100000000000 runs: simulating them together needs "
                                         r"about 16000.0 GB, but .* GB of memory is available"):
        api.simulate(_posg(), REACH, strategies={"rover": FORWARD}, runs=10**11)
