"""Mutation fuzzing of model and property files (issue #13): the corpus, the mutations and the
oracle shared by the bounded hypothesis test (``tests/fuzz/test_fuzz.py``) and the long run
(``benchmarks/fuzz.py``).

The oracle: for a mutated model, ``lint`` and ``build`` (with a small state limit) either succeed
or raise a :class:`~posgmc.errors.PosgmcError` — no other exception escapes — and syntax or
semantic errors carry a position. ``lint`` accepts exactly what ``build`` can at least start on:
a model lint finds clean is never refused by build for its syntax or meaning (build may still
meet an undefined constant, a runtime error in a state, a limit or an unsupported feature), and a
model build accepts has no lint error. For a mutated properties file (with its model intact),
``lint`` and parsing the properties raise nothing but ``PosgmcError``.
"""

from __future__ import annotations

import random
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path

from posgmc import api
from posgmc.compiler import BuildOptions, ProgressMode
from posgmc.errors import (
    BuildError,
    ConstantError,
    LimitError,
    ParseError,
    PosgmcError,
    SemanticError,
    UnsupportedError,
)

ROOT = Path(__file__).resolve().parents[2]
MODEL_SUFFIXES = {".prism", ".nm", ".pm", ".smg", ".posg", ".templ"}
PROPERTY_SUFFIXES = {".props", ".pctl"}
STATE_LIMIT = 3000


def corpus() -> tuple[list[Path], list[tuple[Path, Path]]]:
    """(model files, (model, properties) pairs) under models/ and tests/ (which holds the vendored
    benchmark models, tests/data/benchmarks)."""
    roots = [ROOT / "models", ROOT / "tests"]
    models: list[Path] = []
    pairs: list[tuple[Path, Path]] = []
    for root in roots:
        for path in sorted(root.rglob("*")):
            if not path.is_file():
                continue
            if path.suffix in MODEL_SUFFIXES:
                models.append(path)
            elif path.suffix in PROPERTY_SUFFIXES:
                beside = [m for m in sorted(path.parent.iterdir()) if m.suffix in MODEL_SUFFIXES]
                if beside:
                    pairs.append((beside[0], path))
    return models, pairs


# -- mutations ------------------------------------------------------------------------------------

_TOKEN = re.compile(r'\s+|"[^"\n]*"|[A-Za-z_][A-Za-z_0-9]*|\d+(?:\.\d*)?(?:[eE][+-]?\d+)?|\S')
_NUMBER = re.compile(r"\d+(?:\.\d*)?(?:[eE][+-]?\d+)?")
EXTREMES = (
    "0", "-1", "9223372036854775807", "9223372036854775808", "18446744073709551616",
    "99999999999999999999", "1e308", "1e309", "1e-400", "0.0000000000000000000001",
    "4.9e-324", "2147483648", "-9223372036854775808", "1e999999999",
)
STRANGE = (
    "\x00", "\x01", "\x07", "\x0b", "\x0c", "\x1b", "\x7f", "\x85", "\u00e9", "\u2028", "\u2029",
    "\ufeff", "\u200b", "\U0001f600", "\ud7ff", "\r", "\t", "\\", "'", '"', "@", "$", "#", "`",
)
HUGE = (
    "9" * 5000,
    "1e99999",
    "0." + "0" * 4000 + "1",
    "0." + "0" * 6000 + "1",
    "x" * 3000,
    '"' + "l" * 2000 + '"',
    "(" * 300,
)


def tokens(text: str) -> list[str]:
    return _TOKEN.findall(text)


def mutate(text: str, rng: random.Random, steps: int = 1) -> str:
    """``text`` after ``steps`` random mutations (each picked uniformly among the kinds)."""
    toks = tokens(text) or [""]
    for _ in range(steps):
        if not toks:
            toks = [""]
        kind = rng.randrange(8)
        i = rng.randrange(len(toks))
        if kind == 0 and len(toks) > 1:  # delete a token
            del toks[i]
        elif kind == 1:  # duplicate a token
            toks.insert(i, toks[i])
        elif kind == 2:  # swap two tokens
            j = rng.randrange(len(toks))
            toks[i], toks[j] = toks[j], toks[i]
        elif kind == 3:  # a number becomes an extreme one
            numbers = [k for k, t in enumerate(toks) if _NUMBER.fullmatch(t)]
            k = rng.choice(numbers) if numbers else i
            toks[k] = rng.choice(EXTREMES)
        elif kind == 4:  # a strange character
            toks.insert(i, rng.choice(STRANGE))
        elif kind == 5:  # a huge literal
            toks.insert(i, rng.choice(HUGE))
        elif kind == 6:  # cut the text
            toks = toks[:i]
        else:  # a token from elsewhere in the file
            toks.insert(i, rng.choice(toks))
    return "".join(toks)


# -- the oracle -----------------------------------------------------------------------------------


class OracleFailure(AssertionError):
    """A mutated input broke a rule of the oracle; the message says which and shows the input."""


_POSITIONED = (ParseError, SemanticError)
_BUILD_MAY_STILL_REFUSE = (ConstantError, BuildError, LimitError, UnsupportedError)


@dataclass(frozen=True)
class Outcome:
    lint_clean: bool
    built: bool


def _errors_of(e: PosgmcError) -> list[PosgmcError]:
    return list(getattr(e, "errors", None) or [e])


def _require_positions(errors: list[PosgmcError], what: str, text: str) -> None:
    for e in errors:
        for one in _errors_of(e):
            if isinstance(one, _POSITIONED) and one.span is None:
                raise OracleFailure(
                    f"{what}: {type(one).__name__} without a position: {one}\n{text!r:.2000}"
                )


def check_model_text(text: str, suffix: str, directory: Path) -> Outcome:
    """Apply the oracle to a model text (written to ``directory``)."""
    path = directory / f"fuzz{suffix}"
    path.write_bytes(text.encode("utf-8", errors="surrogatepass"))
    try:
        lint_errors = api.lint(path)
    except PosgmcError as e:  # lint may also raise for a file-level problem
        lint_errors = [e]
    except Exception as e:
        raise OracleFailure(f"lint raised {type(e).__name__}: {e}\n{text!r:.2000}") from e
    _require_positions(lint_errors, "lint", text)
    build_error: PosgmcError | None = None
    try:
        session = api.load(path)
        api.build(
            session, options=BuildOptions(state_limit=STATE_LIMIT, progress=ProgressMode.NEVER)
        )
    except LimitError:
        pass  # it started: the limit stopped it
    except PosgmcError as e:
        build_error = e
    except Exception as e:
        raise OracleFailure(f"build raised {type(e).__name__}: {e}\n{text!r:.2000}") from e
    if build_error is not None:
        _require_positions([build_error], "build", text)
    if not lint_errors and build_error is not None and not all(
        isinstance(x, _BUILD_MAY_STILL_REFUSE) for x in _errors_of(build_error)
    ):
        raise OracleFailure(
            f"lint found nothing but build refused: {type(build_error).__name__}: {build_error}"
            f"\n{text!r:.2000}"
        )
    if lint_errors and build_error is None:
        raise OracleFailure(
            f"build accepted what lint refused: {lint_errors[0]}\n{text!r:.2000}"
        )
    return Outcome(lint_clean=not lint_errors, built=build_error is None)


def check_properties_text(model: Path, text: str, directory: Path) -> None:
    """Apply the oracle to a properties text checked against ``model``."""
    path = directory / "fuzz.props"
    path.write_bytes(text.encode("utf-8", errors="surrogatepass"))
    try:
        errors = api.lint(model, [path])
        _require_positions(errors, "lint", text)
        api.parse_properties(api.load(model), files=[path])
    except PosgmcError as e:
        _require_positions([e], "properties", text)
    except Exception as e:
        raise OracleFailure(f"properties raised {type(e).__name__}: {e}\n{text!r:.2000}") from e


def scratch() -> tempfile.TemporaryDirectory[str]:
    return tempfile.TemporaryDirectory(prefix="posgmc-fuzz-")
