"""The Python API validates its arguments and raises documented PosgmcError subclasses (issue #13)."""

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
        (lambda: api.check(api.load(ROVER), options={"precision": 1}), "options must be a CheckOptions"),
        (lambda: api.check(api.load(ROVER), properties=[1]), "properties must be a string or a list"),
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
