"""Fuzzing the newer surface: strategy files, command-line option values and library arguments.

Shared by the bounded test (``tests/fuzz/test_surface.py``) and the long run
(``benchmarks/fuzz.py --surface ...``). Each input is drawn from ``random.Random`` so that any
failure replays from its index.

* **strategy files**: the bundled strategies (``models/*/*.fss.json``) with a value at a random
  JSON path replaced by an extreme one (a 5001-digit integer, 10^30, 2^63, -1, 1e308, NaN-like
  text, strings, null, lists, objects, nesting 3000 deep), keys deleted, unknown keys added,
  rules duplicated or multiplied (up to 2000 for unseen observations), ``memory_size`` made huge,
  or the text cut or given a stray character. Oracle: reading raises nothing but a
  :class:`~posgmc.errors.PosgmcError` that names the file and a JSON path (or a line and
  column); a strategy that reads is written back to the same text, shown as a table, and checked
  against its model, again raising nothing but a ``PosgmcError``.
* **option values**: ``check``, ``simulate``, ``show-strategy`` and ``build`` of the rover with
  one to three options set to values drawn from a list of hostile ones (``nan``, ``inf``,
  ``-1``, ``0``, 20-digit numbers, empty text, ranges, ``PLAYER=`` forms, paths under a file).
  Oracle: exit code 0, 1 or 2, no ``internal error``, and done within two minutes (every run has
  a time budget of at most two seconds).
* **library arguments**: ``load``, ``build``, ``check``, ``synthesize``, ``simulate``,
  ``load_strategy`` and ``save_strategy`` with one argument replaced by a hostile value (None,
  numbers, bytes, NaN, lists, dicts, objects). Oracle: the call returns or raises a
  ``PosgmcError``; nothing else escapes.
"""

from __future__ import annotations

import json
import math
import random
from collections.abc import Callable
from pathlib import Path
from typing import Any

from click.testing import CliRunner

from posgmc import api
from posgmc.cli import main
from posgmc.errors import InputError, PosgmcError
from posgmc.strategies.files import dump_strategy, parse_strategy
from posgmc.strategies.fss import StrategyError
from posgmc.strategies.render import strategy_table
from tests.fuzz.mutate import OracleFailure

ROOT = Path(__file__).resolve().parents[2]
STRATEGY_FILES = sorted((ROOT / "models").glob("*/*.fss.json"))
MODELS = {"rover": ROOT / "models" / "rover.posg",
          "convoy": ROOT / "models" / "convoy" / "convoy.posg"}
PROPERTIES = {"rover": '<<rover>> Pmax=? [ F "goal" ]',
              "convoy": '<<convoy>> Pmax=? [ F "arrived" ]'}

_BIG = "__BIG__"
_EXTREMES: list[Any] = [
    _BIG, 10**30, 2**63, -(2**63) - 1, -1, 0, 1, 2, 1e308, 1e-320, 1.0000001, 0.5, -0.0,
    "x", "", "NaN", None, True, False, [], {}, [0], {"": 0}, "9" * 100, 2**31, 1_000_000,
]


# -- strategy files --------------------------------------------------------------------------

def _paths(doc: Any, here: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every JSON path of ``doc`` (tuples of keys and indices)."""
    out = [here]
    if isinstance(doc, dict):
        for k, v in doc.items():
            out += _paths(v, here + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            out += _paths(v, here + (i,))
    return out


def _at(doc: Any, path: tuple[Any, ...]) -> Any:
    for key in path:
        doc = doc[key]
    return doc


def _mutate_doc(doc: Any, rng: random.Random) -> Any:
    paths = [p for p in _paths(doc) if p]
    kind = rng.randrange(6)
    if kind == 0 or not paths:  # a value replaced by an extreme one
        if paths:
            path = rng.choice(paths)
            _at(doc, path[:-1])[path[-1]] = rng.choice(_EXTREMES)
    elif kind == 1:  # a key deleted
        keyed = [p for p in paths if isinstance(_at(doc, p[:-1]), dict)]
        if keyed:
            path = rng.choice(keyed)
            del _at(doc, path[:-1])[path[-1]]
    elif kind == 2:  # an unknown key
        dicts = [p for p in [(), *paths] if isinstance(_at(doc, p), dict)]
        _at(doc, rng.choice(dicts))[rng.choice(["extra", "9" * 60, "", "action "])] = 1
    elif kind == 3 and isinstance(doc.get("rules"), list) and doc["rules"]:
        rule = rng.choice(doc["rules"])
        if rng.random() < 0.5:
            doc["rules"].append(json.loads(json.dumps(rule)))  # a second rule for one pair
        else:  # many rules for observations the model never shows
            many = []
            for i in range(rng.choice([10, 200, 2000])):
                r = json.loads(json.dumps(rule))
                if isinstance(r, dict) and isinstance(r.get("observation"), dict):
                    r["observation"] = {k: 1000 + i for k in r["observation"]}
                many.append(r)
            doc["rules"] += many
    elif kind == 4:
        doc["memory_size"] = rng.choice([_BIG, 10**6, 2**31 - 1, 2**31, 10**30, 0, -5, 3])
    else:  # a rule's update sends to a huge or missing node
        rules = doc.get("rules") if isinstance(doc, dict) else None
        if isinstance(rules, list) and rules and isinstance(rules[0], dict):
            rule = rng.choice(rules)
            acts = rule.get("action") if isinstance(rule, dict) else None
            if isinstance(acts, dict) and acts:
                label = next(iter(acts))
                node = rng.choice(["1" + "0" * 5000, "-1", "01", "999999", "x", ""])
                rule["update"] = {label: {node: 1.0}}
    return doc


def strategy_text(rng: random.Random) -> tuple[str, str]:
    """(the name of the bundled model, a mutated strategy file's text)."""
    path = rng.choice(STRATEGY_FILES)
    model = "rover" if path.parent.name == "rover" else "convoy"
    doc = json.loads(path.read_text(encoding="utf-8"))
    for _ in range(rng.randint(1, 3)):
        doc = _mutate_doc(doc, rng)
    text = json.dumps(doc).replace(f'"{_BIG}"', "1" + "0" * 5000)
    r = rng.random()
    if r < 0.08:
        text = text[: rng.randrange(len(text) + 1)]
    elif r < 0.14:
        i = rng.randrange(len(text) + 1)
        stray = rng.choice(["\x00", "\ufeff", "]", "{", "1e999", "-", "\u2028"])
        text = text[:i] + stray + text[i:]
    elif r < 0.16:
        text = '{"rules": ' + "[" * 3000 + "]" * 3000 + "}"
    return model, text


def check_strategy_text(model: str, text: str, directory: Path) -> str:
    """Apply the oracle to one strategy file; its outcome ("refused", "read", "checked")."""
    file = directory / "s.json"
    file.write_text(text, encoding="utf-8")
    try:
        fss = parse_strategy(text, file=str(file))
    except StrategyError as e:
        if e.file != str(file) or not e.path:
            raise OracleFailure(f"strategy error without file or JSON path: {e}") from e
        return "refused"
    except InputError as e:
        if e.span is None and str(file) not in e.message:
            raise OracleFailure(f"strategy input error without a position: {e}") from e
        return "refused"
    except Exception as e:  # noqa: BLE001 - the oracle: nothing but a PosgmcError
        raise OracleFailure(f"reading a strategy raised {type(e).__name__}: {e}") from e
    try:
        again = dump_strategy(fss)
        if dump_strategy(parse_strategy(again)) != again:
            raise OracleFailure("a strategy written and read back is written differently")
        if fss.num_rules <= 5000:
            strategy_table(fss)
        api.check(api.load(MODELS[model]), properties=[PROPERTIES[model]],
                  strategies={None: str(file)})
    except PosgmcError:
        return "read"
    except OracleFailure:
        raise
    except Exception as e:  # noqa: BLE001
        raise OracleFailure(f"using a strategy raised {type(e).__name__}: {e}") from e
    return "checked"


# -- option values ---------------------------------------------------------------------------

_NUMBERS = ["nan", "inf", "-inf", "-1", "0", "1e999", "99999999999999999999", "", "abc", "0.5",
            "1", "-0", "1e-300"]
# a huge but valid budget is a legitimately long run, not a hostile value: at most 2 seconds here
_TIMEOUTS = [v for v in _NUMBERS if v not in ("99999999999999999999",)] + ["2"]
_SECONDS = 120
"""The longest a command line may run: longer is a failure (a budget or deadline not held)."""


class _TookTooLong(BaseException):  # noqa: N818 - not an Exception, so CliRunner lets it through
    pass


def _alarm(*_: object) -> None:
    raise _TookTooLong


_OPTIONS: dict[str, list[list[str]]] = {
    "check": [
        ["--timeout", *_TIMEOUTS], ["--memory", "0", "-1", "1..200", "200..1", "auto", "rover=0",
                                   "nobody=1", "99999999999999999999", "", "1..", "attacker=3"],
        ["--jobs", *_NUMBERS], ["--seed", *_NUMBERS], ["--precision", *_NUMBERS],
        ["--adversaries", *_NUMBERS], ["--state-limit", *_NUMBERS],
        ["--const", "N=", "N=1e999", "N=99999999999999999999", "N=3:1", "N=1:2:0", "Q=1", "="],
        ["--strategy", "rover=", "=x", "nobody=models/rover/forward.fss.json", "rover=/dev/null",
         "rover=models"],
        ["--export-strategy", "", "/dev/full", "models/rover.posg/x", "/proc/version"],
    ],
    "simulate": [
        ["--runs", *_NUMBERS], ["--max-steps", *_NUMBERS], ["--seed", *_NUMBERS],
        ["--opponent", "best", "uniform", "", "worst"],
        ["--strategy", "rover=models/rover/forward.fss.json", "rover=", "x"],
    ],
    "show-strategy": [["--model", "models/rover.posg", "models", "", "/dev/null"]],
    "build": [["--state-limit", *_NUMBERS], ["--const", "N=0", "N=-1", "N=99999999999999999999",
                                             "BUDGET=1e9"]],
}
_FIXED = {
    "check": ["models/rover.posg", "--prop", PROPERTIES["rover"]],
    "simulate": ["models/rover.posg", "--prop", PROPERTIES["rover"], "--runs", "50"],
    "show-strategy": ["models/rover/forward.fss.json"],
    "build": ["models/rover.posg"],
}


def option_arguments(rng: random.Random) -> list[str]:
    """A command line: one of the commands with one to three options set to hostile values."""
    command = rng.choice(sorted(_OPTIONS))
    args = [command, *_FIXED[command]]
    for _ in range(rng.randint(1, 3)):
        name, *values = rng.choice(_OPTIONS[command])
        args += [name, rng.choice(values)]
    if command == "check" and "--timeout" not in args:
        args += ["--timeout", "1"]
    if command == "check" and "--memory" not in args:
        args += ["--memory", "1"]
    return args


def check_option_arguments(args: list[str], directory: Path) -> str:
    """Run one command line in ``directory`` (the model paths made absolute); its exit code."""
    fixed = [str(ROOT / a) if a.startswith("models") else
             (a.split("=", 1)[0] + "=" + str(ROOT / a.split("=", 1)[1])
              if "=models" in a else a) for a in args]
    import signal

    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(_SECONDS)
    try:
        with _cwd(directory):
            result = CliRunner().invoke(main, fixed)
    except _TookTooLong:
        raise OracleFailure(f"posgmc {' '.join(args)}: still running after {_SECONDS} s") from None
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    if "internal error" in result.output or result.exit_code not in (0, 1, 2):
        raise OracleFailure(f"posgmc {' '.join(args)}: exit {result.exit_code}: "
                            f"{result.output.strip().splitlines()[-1:] or result.exception!r}")
    return f"exit {result.exit_code}"


class _cwd:  # noqa: N801 - a context manager used like a function
    def __init__(self, path: Path) -> None:
        self.path, self.old = path, Path.cwd()

    def __enter__(self) -> None:
        import os

        os.chdir(self.path)

    def __exit__(self, *_: object) -> None:
        import os

        os.chdir(self.old)


# -- library arguments -----------------------------------------------------------------------

_VALUES: list[Any] = [None, 5, -1, 0, 1.5, math.nan, math.inf, b"x", "", "5", "a", [], [None],
                      {}, {"rover": None}, (2, 1), object(), True, 10**30]


def _calls(directory: Path) -> dict[str, tuple[Callable[..., Any], dict[str, Any]]]:
    rover = str(MODELS["rover"])
    forward = str(ROOT / "models" / "rover" / "forward.fss.json")
    return {
        "load": (api.load, {"path": rover, "constants": {"N": 6}}),
        "build": (lambda **kw: api.build(api.load(rover), **kw), {"options": None}),
        "check": (lambda **kw: api.check(api.load(rover), **kw),
                  {"properties": [PROPERTIES["rover"]], "strategies": {"rover": forward}}),
        "synthesize": (lambda **kw: api.synthesize(api.load(rover), PROPERTIES["rover"], **kw),
                       {"memory": 1, "timeout": 0.5, "seed": 0, "jobs": 1, "adversaries": 0}),
        "simulate": (lambda **kw: api.simulate(api.load(rover), PROPERTIES["rover"], **kw),
                     {"strategies": {"rover": forward}, "runs": 20, "seed": 0, "max_steps": 50}),
        "load_strategy": (lambda **kw: api.load_strategy(**kw), {"path": forward}),
        "save_strategy": (lambda **kw: api.save_strategy(**kw),
                          {"strategy": api.load_strategy(forward),
                           "path": str(directory / "o.json")}),
    }


def api_call(rng: random.Random, directory: Path) -> tuple[str, str, Any]:
    """(function, argument, hostile value): one library call with one argument replaced."""
    calls = _calls(directory)
    name = rng.choice(sorted(calls))
    arg = rng.choice(sorted(calls[name][1]))
    return name, arg, rng.choice(_VALUES)


def check_api_call(name: str, arg: str, value: Any, directory: Path) -> str:
    """Apply the oracle to one library call: it returns or raises a ``PosgmcError``."""
    function, kwargs = _calls(directory)[name]
    kwargs = {**kwargs, arg: value}
    try:
        with _cwd(directory):
            function(**kwargs)
    except PosgmcError:
        return "refused"
    except Exception as e:  # noqa: BLE001 - the oracle
        raise OracleFailure(f"api.{name}({arg}={value!r}) raised {type(e).__name__}: {e}") from e
    return "returned"
