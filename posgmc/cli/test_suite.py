"""What ``posgmc test PATH...`` runs, found as PRISM's test mode finds it: model files, each
model's properties files, and the argument files that say how to run them.

* A folder is searched (recursively, in name order) for model files: ``.prism``, ``.nm``,
  ``.pm``, ``.smg``, ``.posg``, ``.pomdp``, ``.drn``.
* A model's properties files, beside it: ``M.props`` and ``M.*.props`` for the model's name ``M``
  without its extension (``maze.props``, ``maze.storm.props``), and as PRISM names them with it
  (``maze.pomdp.props``, ``maze.prism.props``); in a folder that holds one model, every
  ``.props`` file of the folder (``full_observation.props``).
* Argument files: ``FILE.args`` beside a model or a properties file (PRISM's ``model.prism.args``,
  ``model.props.args``). Each non-empty line that is not a ``//`` or ``#`` comment is one run, with
  those arguments; the model's lines and its properties file's lines combine (every pair). PRISM's
  switches are read as posgmc's options: ``-const``, ``-exact``, ``-prop`` (``--select``); engine
  and numerical switches that do not apply (``-ex``, ``-mtbdd``, ``-epsilon 1e-8``, ...) are
  ignored; posgmc's own options are taken as they are, and a relative ``--strategy PLAYER=FILE``
  is read from the argument file's folder.
* A properties file given after its model on the command line is run with the command line's
  options only (no argument files): ``posgmc test MODEL PROPS... --memory 2``.
"""

from __future__ import annotations

import shlex
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from posgmc.errors import InputError, SourceSpan

__all__ = ["MODEL_SUFFIXES", "Run", "discover", "read_args_file", "translate"]

MODEL_SUFFIXES = (".prism", ".nm", ".pm", ".smg", ".posg", ".pomdp", ".drn")

# PRISM switches that choose an engine or a numerical method posgmc does not have: ignored, with
# the number of values each takes
_IGNORED = {
    "-ex": 0, "-explicit": 0, "-mtbdd": 0, "-m": 0, "-sparse": 0, "-s": 0, "-hybrid": 0,
    "-h": 0, "-ii": 0, "-intervaliter": 0, "-topological": 0, "-power": 0,
    "-pow": 0, "-jacobi": 0, "-jac": 0, "-gaussseidel": 0, "-gs": 0, "-bgaussseidel": 0,
    "-bgs": 0, "-pgaussseidel": 0, "-pgs": 0, "-politer": 0, "-modpoliter": 0, "-valiter": 0,
    "-relative": 0, "-rel": 0, "-absolute": 0, "-abs": 0, "-nopre": 0, "-noprob0": 0,
    "-noprob1": 0, "-fixdl": 0, "-heuristic": 1, "-epsilon": 1, "-e": 1, "-maxiters": 1,
    "-gridresolution": 1, "-cuddmaxmem": 1, "-javamaxmem": 1, "-javastack": 1, "-timeout": 1,
    "-exportresults": 1, "-exportstrat": 1, "-lp": 0, "-smg_exact": 0,
}
_RENAMED = {"-const": "--const", "-prop": "--select", "-property": "--select"}


@dataclass(frozen=True)
class Run:
    """One run of ``posgmc test``: a model, a properties file, the arguments (posgmc's options)
    and where they come from (``file:line``, or None for the command line's)."""

    model: Path
    props: Path
    args: tuple[str, ...] = ()
    origin: str | None = None


def translate(tokens: Sequence[str], span: SourceSpan, base: Path) -> tuple[str, ...]:
    """An argument line's tokens as posgmc's options (see the module docstring); ``base`` is the
    argument file's folder, ``span`` its line (for errors)."""
    out: list[str] = []
    i = 0
    while i < len(tokens):
        t = tokens[i]
        if t == "-exact":
            out.append("--exact")
        elif t in _RENAMED:
            if i + 1 >= len(tokens):
                raise InputError(f"{t} needs a value", span)
            out += [_RENAMED[t], tokens[i + 1]]
            i += 1
        elif t in _IGNORED:
            i += _IGNORED[t]
        elif t.startswith("--"):
            out.append(t)
            if t == "--strategy" and i + 1 < len(tokens):
                out.append(_strategy_path(tokens[i + 1], base))
                i += 1
        elif t.startswith("-"):
            raise InputError(
                f"unknown switch {t} in an argument file",
                span,
                hint="PRISM's -const, -exact and -prop are read, engine switches ignored; "
                "posgmc's own options are written with two dashes",
            )
        else:
            out.append(t)
        i += 1
    return tuple(out)


def _strategy_path(value: str, base: Path) -> str:
    player, sep, file = value.partition("=")
    path = Path(file if sep else player)
    if path.is_absolute():
        return value
    resolved = str(base / path)
    return f"{player}={resolved}" if sep else resolved


def read_args_file(path: Path) -> list[tuple[tuple[str, ...], str]]:
    """The runs of an argument file: (posgmc options, ``file:line``) per line."""
    runs = []
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        text = line.strip()
        if not text or text.startswith(("//", "#")):
            continue
        span = SourceSpan(n, 1, n, len(line) + 1, str(path))
        try:
            tokens = shlex.split(text)
        except ValueError as e:
            raise InputError(f"cannot split the arguments: {e}", span) from None
        runs.append((translate(tokens, span, path.parent), f"{path}:{n}"))
    return runs


def discover(paths: Sequence[str]) -> list[Run]:
    """The runs the command line names, in order (see the module docstring).

    Raises:
        InputError: a path that does not exist, a properties file before any model, a model
            without properties files, or a malformed argument file.
    """
    runs: list[Run] = []
    pending: Path | None = None  # the last model given, until its explicit props are known
    explicit: list[Path] = []

    def flush() -> None:
        nonlocal pending
        if pending is None:
            return
        if explicit:
            runs.extend(Run(pending, p) for p in explicit)
        else:
            runs.extend(_model_runs(pending, required=True))
        pending = None
        explicit.clear()

    for text in paths:
        path = Path(text)
        if not path.exists():
            raise InputError(f"{text}: no such file or folder")
        if path.is_dir():
            flush()
            models = sorted(
                p for p in path.rglob("*") if p.is_file() and p.suffix in MODEL_SUFFIXES
            )
            for model in models:
                runs.extend(_model_runs(model, required=False))
            continue
        if path.suffix == ".props":
            if pending is None:
                raise InputError(
                    f"{text}: a properties file comes after its model",
                    hint="posgmc test MODEL [PROPS...], or a model or folder alone",
                )
            explicit.append(path)
            continue
        flush()
        pending = path
    flush()
    return runs


def _model_runs(model: Path, *, required: bool) -> list[Run]:
    props = properties_of(model)
    if not props and required:
        raise InputError(
            f"{model}: no properties file beside it",
            hint=f"name one {model.stem}.props or {model.name}.props, or give it after the model",
        )
    model_lines = _args_of(model)
    runs = []
    for p in props:
        for model_args, model_origin in model_lines:
            for props_args, props_origin in _args_of(p):
                origin = ", ".join(o for o in (model_origin, props_origin) if o) or None
                runs.append(Run(model, p, model_args + props_args, origin))
    return runs


def _args_of(path: Path) -> list[tuple[tuple[str, ...], str]]:
    args = path.with_name(path.name + ".args")
    return read_args_file(args) if args.is_file() else [((), "")]


def properties_of(model: Path) -> list[Path]:
    """The properties files of a model (see the module docstring), in name order."""
    folder = model.parent
    stem = model.stem
    names = {f"{stem}.props", f"{model.name}.props"}
    found = {
        p for p in folder.glob("*.props")
        if p.name in names
        or (p.name.startswith(f"{stem}.") and p.name.endswith(".props"))
    }
    others = [p for p in folder.iterdir() if p.is_file() and p.suffix in MODEL_SUFFIXES]
    if len(others) == 1:  # the folder's only model: every properties file is its own
        found |= set(folder.glob("*.props"))
    return sorted(found)
