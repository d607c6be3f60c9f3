"""posgmc on PRISM's own regression suite, graded with PRISM's test-mode rules.

Usage::

    python benchmarks/prism_suite.py PRISM_CHECKOUT [--timeout 60] [--json OUT.json]
                                     [--markdown docs/compatibility.md] [--only SUBSTRING]

``PRISM_CHECKOUT`` is a checkout of ``prismmodelchecker/prism`` (or just its ``prism-tests/``
folder, or that folder's parent); nothing is fetched. The runner follows PRISM's ``prism-auto -t
-m`` (``prism/etc/scripts/prism-auto``): in each folder of the scope, every model file
(``.prism``/``.nm``/``.pm``/``.sm``) is run once per line of its ``.args`` file with every
properties file whose name starts with the model's (``.props``/``.pctl``/``.csl``), once per line of
that file's ``.args``. Argument lines that differ only in PRISM's engine switches (``-ex``, ``-s``,
``-valiter``, ...) ask posgmc the same question and are run once; ``-const`` (ranges too),
``-exact`` and ``-prop`` are honoured; ``-param`` (parametric), ``-ctmc``, ``-fair`` and model-type
overrides are out of scope and skipped with a reason, as are ctmc/pta/interval models.

Each run is a child process (``--worker``) with a time limit, so that a hang costs one run. Every
``// RESULT`` line that applies (PRISM: the first whose constants all match; ``?`` is not graded)
is graded by :func:`posgmc.checking.expected.grade` (PRISM's rules) into one class: ``pass``,
``wrong answer`` (a value that disagrees, or a value where PRISM expects an error), ``parser
refusal``, ``unsupported``, ``semantic rejection``, ``timeout`` or ``internal error``. A property
that posgmc cannot parse is refused alone: its lines are blanked and the rest of the file is parsed
again (PRISM would refuse the whole file), so every other line is still graded.

Not part of the ``posgmc`` package; the suite's files are never copied into posgmc.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
from collections import Counter, defaultdict
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any

SCOPE_RECURSIVE = (
    "functionality/verify/dtmcs",
    "functionality/verify/mdps",
    "functionality/verify/exact",
    "functionality/verify/ctl",
    "pmc",
    "papers",
    "bugfixes",
)
SCOPE_FLAT = ("functionality/verify",)  # its top level only

CLASSES = ("pass", "wrong answer", "parser refusal", "unsupported", "semantic rejection",
           "timeout", "internal error", "deliberate difference")

# Lines where PRISM expects an error but posgmc answers, on purpose: the meaning is defined and
# posgmc's answer is pinned by a regression test (docs/compatibility.md says why). Only an
# expected "Error" line can be listed here, and only a value posgmc proves.
DELIBERATE: dict[tuple[str, int], str] = {
    (
        "functionality/verify/close_bounds.prism.props",
        11,
    ): "PRISM's floating-point engines cannot decide a threshold this close; posgmc refines to "
    "an exact solve (tests/checking/test_close_thresholds.py)",
    (
        "functionality/verify/close_bounds.prism.props",
        15,
    ): "as above (tests/checking/test_close_thresholds.py)",
    (
        "bugfixes/supersimple.pm.boundedltl.props",
        15,
    ): "PRISM has no step-bounded LTL; the nested query is a state formula with a defined "
    "value (tests/checking/test_nested_ltl.py)",
    (
        "bugfixes/supersimple.pm.boundedltl.props",
        17,
    ): "as above (tests/checking/test_nested_ltl.py)",
    (
        "bugfixes/supersimple.pm.boundedltl.props",
        19,
    ): "as above (tests/checking/test_nested_ltl.py)",
}

_MODEL = re.compile(r".+\.(prism|nm|pm|sm)$")
_PROPS = re.compile(r".+\.(props|pctl|csl)$")
_TYPE = re.compile(r"^\s*(dtmc|probabilistic|mdp|nondeterministic|ctmc|stochastic|pta|pomdp|popta|"
                   r"ctmdp|smg|csg|tsg|lts|idtmc|imdp|ipomdp)\b", re.MULTILINE)
_INTERVAL_UPDATE = re.compile(r"\[\s*[-+.\w()*/ ]+,\s*[-+.\w()*/ ]+\]\s*:")
_TYPE_NAMES = {"probabilistic": "dtmc", "nondeterministic": "mdp", "stochastic": "ctmc"}

# switches that only choose PRISM's engine, method or output: the same question for posgmc
_IGNORED_SWITCHES = {
    "ex", "explicit", "s", "sparse", "h", "hybrid", "m", "mtbdd", "valiter", "ii", "gs", "bgs",
    "pgs", "jacobi", "power", "politer", "modpoliter", "lp", "topological", "nopre", "sim",
    "pathviaautomata", "noprobchecks", "nossdetect", "fixdl", "nofair", "hybrid-explicit",
    "hybrid-const", "gs-explicit", "exportresults", "exportvector", "exportstrat", "e",
    "maxiters", "cuddepsilon", "paretoepsilon", "transientmethod", "ptamethod", "test", "testall",
}
_SWITCHES_WITH_VALUE = {"e", "maxiters", "cuddepsilon", "paretoepsilon", "transientmethod",
                        "ptamethod", "exportresults", "exportvector", "exportstrat", "const",
                        "prop", "param"}


# ---------------------------------------------------------------------------------------------
# discovery (prism-auto's rules)
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Run:
    """One invocation: a model, one properties file, the canonical arguments posgmc needs."""

    folder: str
    model: str
    props: str
    consts: tuple[str, ...]
    exact: bool
    prop: str | None
    skip: str | None  # why the run is out of scope, or None

    @property
    def args_text(self) -> str:
        parts = [f"-const {c}" for c in self.consts]
        if self.exact:
            parts.append("-exact")
        if self.prop:
            parts.append(f"-prop {self.prop}")
        return " ".join(parts)


def _args_lines(path: Path) -> list[list[str]]:
    """prism-auto's ``getMatchingArgListsForFile``: one list per non-comment line, or ``[[]]``."""
    args = path.with_name(path.name + ".args")
    if not args.is_file():
        return [[]]
    lines = []
    for line in args.read_text(errors="replace").splitlines():
        line = line.strip()
        if line and not line.startswith("#"):
            lines.append([item for item in line.split(" ") if item])
    return lines or [[]]


def _model_type(text: str) -> str:
    code = re.sub(r"//[^\n]*", "", text)
    m = _TYPE.search(code)
    kind = _TYPE_NAMES.get(m.group(1), m.group(1)) if m else "mdp"
    if kind in ("dtmc", "mdp") and _INTERVAL_UPDATE.search(code):
        return "interval " + kind
    return kind


def _canonical(
    model: Path, args: Sequence[str]
) -> tuple[tuple[str, ...], bool, str | None, str | None]:
    """(consts, exact, prop, skip reason) from a PRISM argument list."""
    consts: list[str] = []
    exact = False
    prop: str | None = None
    skip: str | None = None
    kind = _model_type(model.read_text(errors="replace"))
    i = 0
    while i < len(args):
        switch = args[i].lstrip("-")
        value = args[i + 1] if i + 1 < len(args) else ""
        if switch == "const":
            consts.append(value)
        elif switch == "exact":
            exact = True
        elif switch == "prop":
            prop = value
        elif switch == "param":
            skip = skip or "parametric model checking (-param)"
        elif switch == "fair":
            skip = skip or "fairness (-fair)"
        elif switch in ("dtmc", "mdp", "ctmc"):
            if switch != kind:
                skip = skip or f"model type override -{switch} on a {kind}"
        elif switch not in _IGNORED_SWITCHES:
            skip = skip or f"PRISM switch -{switch}"
        i += 2 if switch in _SWITCHES_WITH_VALUE else 1
    if kind not in ("dtmc", "mdp"):
        skip = skip or f"{kind} model"
    return tuple(consts), exact, prop, skip


def _folders(tests: Path) -> Iterator[Path]:
    for rel in SCOPE_FLAT:
        yield tests / rel
    for rel in SCOPE_RECURSIVE:
        root = tests / rel
        if root.is_dir():
            yield from sorted(p for p in [root, *root.rglob("*")] if p.is_dir())


def discover(tests: Path) -> list[Run]:
    """Every run of the scope, deduplicated on the arguments posgmc honours."""
    runs: list[Run] = []
    seen: set[tuple[str, str, tuple[str, ...], bool, str | None, str | None]] = set()
    for folder in _folders(tests):
        files = sorted(os.listdir(folder))
        for model_name in (f for f in files if _MODEL.match(f) and (folder / f).is_file()):
            model = folder / model_name
            for margs in _args_lines(model):
                for props_name in (
                    f for f in files if _PROPS.match(f) and f.startswith(model_name)
                ):
                    props = folder / props_name
                    for pargs in _args_lines(props):
                        consts, exact, prop, skip = _canonical(model, [*margs, *pargs])
                        key = (str(model), str(props), consts, exact, prop, skip)
                        if key in seen:
                            continue
                        seen.add(key)
                        runs.append(Run(str(folder.relative_to(tests)), str(model), str(props),
                                        consts, exact, prop, skip))
    return runs


# ---------------------------------------------------------------------------------------------
# the worker: one run in a child process
# ---------------------------------------------------------------------------------------------


def _chunks(lines: Sequence[str]) -> list[tuple[int, int]]:
    """Line ranges ``[first, last]`` (0-based) of the file's items: each item's comments and code,
    ending at the first code line after which brackets balance."""
    chunks: list[tuple[int, int]] = []
    start, depth = 0, 0
    for i, line in enumerate(lines):
        code = line.split("//", 1)[0]
        for ch in code:
            depth += ch in "([{"
            depth -= ch in ")]}"
        if code.strip() and depth <= 0:
            chunks.append((start, i))
            start, depth = i + 1, 0
    if start < len(lines):
        chunks.append((start, len(lines) - 1))
    return chunks


@dataclass(frozen=True)
class _Refused:
    line: int
    text: str
    expected: tuple[Any, ...]
    error: Any


def _parse_with_recovery(path: Path) -> tuple[str, list[_Refused]]:
    """The file's text with every property posgmc cannot parse blanked out, and those properties
    (with their RESULT lines and the error a user sees)."""
    from posgmc.errors import MultipleErrors, PosgmcError
    from posgmc.syntax import parser

    lines = path.read_text(errors="replace").splitlines(keepends=True)
    chunks = _chunks(lines)
    refused: list[_Refused] = []
    for _ in range(len(chunks) + 1):
        text = "".join(lines)
        try:
            parser.parse_properties(text, file=str(path))
            return text, refused
        except PosgmcError as err:
            first = err.errors[0] if isinstance(err, MultipleErrors) else err
            line = first.span.line if first.span is not None and first.span.line else len(lines)
            candidates = [c for c in chunks if c[0] <= line - 1 <= c[1]] or [
                c for c in chunks if c[1] <= line - 1 and any(ln.split("//")[0].strip()
                                                             for ln in lines[c[0]:c[1] + 1])][-1:]
            if not candidates:
                raise
            first_line, last_line = candidates[0]
            chunks.remove(candidates[0])
            block = lines[first_line:last_line + 1]
            comments = "".join(ln if ln.lstrip().startswith("//") else "\n" for ln in block)
            code_at = next((first_line + k for k, ln in enumerate(block)
                            if ln.split("//")[0].strip()), first_line)
            try:
                expected = parser.parse_properties(comments + "true\n").properties[0].expected
            except PosgmcError:
                expected = ()
            code = " ".join(ln.split("//")[0].strip() for ln in block).strip()
            refused.append(_Refused(code_at + 1, code, expected, first))
            for k in range(first_line, last_line + 1):
                lines[k] = "\n"
    raise RuntimeError("parse recovery did not converge")


def _classify(outcome: Any) -> str:
    from posgmc.errors import (
        LimitError,
        MultipleErrors,
        ParseError,
        PosgmcError,
        UnsupportedError,
    )

    if isinstance(outcome, MultipleErrors) and outcome.errors:
        outcome = outcome.errors[0]
    if isinstance(outcome, ParseError):
        return "parser refusal"
    if isinstance(outcome, UnsupportedError):
        return "unsupported"
    if isinstance(outcome, LimitError):
        return "timeout"
    if isinstance(outcome, PosgmcError):
        return "semantic rejection"
    return "internal error"


def _message(err: Any, tmp: str, real: str) -> str:
    text = err.render() if hasattr(err, "render") else f"{type(err).__name__}: {err}"
    return str(text).replace(tmp, real)


def _emit(record: dict[str, Any]) -> None:
    sys.stdout.write(json.dumps(record) + "\n")
    sys.stdout.flush()


def worker(spec: dict[str, Any]) -> None:
    """Check one run and print one JSON line per graded RESULT line (after a ``plan`` line)."""
    from posgmc import api
    from posgmc.checking.expected import Verdict, expected_for, grade
    from posgmc.checking.property_checker import CheckOptions
    from posgmc.cli.constants import const_text, expand_constants
    from posgmc.compiler.options import BuildOptions
    from posgmc.errors import PosgmcError

    model, props = spec["model"], Path(spec["props"])
    exact, only = bool(spec["exact"]), spec["prop"]
    _, combos = expand_constants(spec["consts"])
    text, refused = _parse_with_recovery(props)
    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir) / props.name
        tmp.write_text(text)
        from posgmc.syntax import parser

        pfile = parser.parse_properties(text, file=str(tmp))
        parsed = pfile.properties
        try:
            declared = (*parser.load_model(model).constants, *pfile.constants)
        except PosgmcError:
            declared = tuple(pfile.constants)

        def wanted(index: int, prop: Any) -> bool:
            if only is None:
                return True
            return prop.name == only or (only.isdigit() and int(only) == index + 1)

        for constants in combos or [{}]:
            given = {n: const_text(v) for n, v in constants.items()}
            label = ",".join(f"{n}={v}" for n, v in given.items())
            # PRISM matches RESULT (c=v) against every constant, the defined ones too
            texts = _defined_constants(declared, given)
            plan: dict[int, Any] = {}
            for i, prop in enumerate(parsed):
                exp = expected_for(prop, texts)
                if wanted(i, prop) and exp is not None and exp.text.strip() != "?":
                    plan[prop.span.line] = exp
            _emit({"plan": sorted(plan), "consts": label})
            base = {"consts": label}
            for r in refused:
                exp = expected_for(r, texts)  # type: ignore[arg-type]
                if exp is None or exp.text.strip() == "?":
                    continue
                verdict = grade(exp, r.error, constants=texts)
                _emit(
                    {
                        **base,
                        "line": r.line,
                        "property": r.text,
                        "expected": exp.text,
                        "class": "pass" if verdict.passed else _classify(r.error),
                        "actual": verdict.actual,
                        "message": _message(r.error, str(tmp), str(props)),
                    }
                )
            if not plan:
                continue
            try:
                session = api.load(model, constants=constants)
                built = api.build(session, allow_extra_constants=True,
                                  options=BuildOptions(exact=exact))
                outcomes = api.iter_check(session, property_files=[tmp], built=built,
                                          options=CheckOptions(exact=exact))
                pairs = ((p, o) for p, o in outcomes if p.span.line in plan)
            except PosgmcError as err:
                failure = err
                pairs = ((p, failure) for p in parsed if p.span.line in plan)
            for prop, outcome in _guarded(pairs, parsed, plan):
                exp = plan[prop.span.line]
                try:
                    verdict = (grade(exp, outcome, constants=texts) if not isinstance(
                        outcome, BaseException) or isinstance(outcome, PosgmcError)
                        else Verdict(False, exp.text, "-"))
                except ValueError as bad:
                    _emit({**base, "line": prop.span.line, "property": prop.text,
                           "expected": exp.text, "class": "internal error", "actual": "-",
                           "message": f"runner: {bad}"})
                    continue
                if isinstance(outcome, BaseException) and not isinstance(outcome, PosgmcError):
                    kind = "internal error"
                elif verdict.passed:
                    kind = "pass"
                elif isinstance(outcome, BaseException):
                    kind = _classify(outcome)
                elif _undecided(outcome, exp.text):
                    kind = "timeout"  # ran out of iterations; its bounds still allow PRISM's value
                else:
                    kind = "wrong answer"
                record = {**base, "line": prop.span.line, "property": prop.text,
                          "expected": exp.text, "class": kind, "actual": verdict.actual}
                if isinstance(outcome, BaseException):
                    record["message"] = _message(outcome, str(tmp), str(props))
                else:
                    record["sound"] = bool(getattr(outcome, "sound", False))
                    if kind == "timeout":
                        record["message"] = (f"not decided: bounds [{outcome.lower}, "
                                             f"{outcome.upper}], converged={outcome.converged}")
                _emit(record)


def _undecided(outcome: Any, expected: str) -> bool:
    """An answer that did not converge (or a Boolean left undecided) whose proven bounds still
    contain PRISM's value: a resource limit, not a wrong answer."""
    if getattr(outcome, "value", 0) is None:
        return True
    if getattr(outcome, "converged", True):
        return False
    lower, upper = getattr(outcome, "lower", None), getattr(outcome, "upper", None)
    try:
        wanted = float(Fraction(expected.lstrip("~")))
    except (ValueError, ZeroDivisionError):
        return False
    return lower is not None and upper is not None and lower <= wanted <= upper


def _defined_constants(declared: Sequence[Any], given: dict[str, str]) -> dict[str, str]:
    """``given`` (the -const values) and every declared constant whose definition evaluates, as
    text (PRISM's ``RESULT (N=4)`` may name a constant defined in the file)."""
    from posgmc.checking.expected import _constant_value
    from posgmc.errors import PosgmcError
    from posgmc.semantics.evaluate import evaluate, format_value

    texts = dict(given)
    env: dict[str, Any] = {}
    for name, text in given.items():
        try:
            env[name] = _constant_value(text)
        except (ValueError, ZeroDivisionError):
            pass
    for decl in declared:
        if decl.name in env or decl.value is None:
            continue
        try:
            value = evaluate(decl.value, env)
        except (PosgmcError, ValueError, TypeError, ZeroDivisionError, KeyError):
            continue
        env[decl.name] = value
        texts[decl.name] = format_value(value)
    return texts


def _guarded(pairs: Iterator[tuple[Any, Any]], parsed: Sequence[Any],
             plan: dict[int, Any]) -> Iterator[tuple[Any, Any]]:
    """The pairs; an exception escaping the checker (a bug) becomes every remaining line's
    internal error instead of ending the run."""
    done: set[int] = set()
    try:
        for prop, outcome in pairs:
            done.add(prop.span.line)
            yield prop, outcome
    except Exception as bug:  # noqa: BLE001 - reported as an internal error, never swallowed
        for prop in parsed:
            if prop.span.line in plan and prop.span.line not in done:
                yield prop, bug


# ---------------------------------------------------------------------------------------------
# the driver
# ---------------------------------------------------------------------------------------------


def _run_one(run: Run, tests: Path, timeout: float) -> tuple[list[dict[str, Any]], float]:
    spec = {"model": run.model, "props": run.props, "consts": list(run.consts),
            "exact": run.exact, "prop": run.prop}
    started = time.perf_counter()
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    try:
        proc = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--worker",
                               json.dumps(spec)], capture_output=True, text=True,
                              timeout=timeout, env=env, check=False)
        out, err, timed_out, crashed = proc.stdout, proc.stderr, False, proc.returncode != 0
    except subprocess.TimeoutExpired as e:
        out = e.stdout.decode() if isinstance(e.stdout, bytes) else (e.stdout or "")
        err, timed_out, crashed = "", True, False
    seconds = time.perf_counter() - started
    records: list[dict[str, Any]] = []
    planned: list[tuple[str, int]] = []
    for line in out.splitlines():
        if not line.startswith("{"):
            continue
        rec = json.loads(line)
        if "plan" in rec:
            planned += [(rec["consts"], n) for n in rec["plan"]]
        else:
            records.append(rec)
    graded = {(r["consts"], r["line"]) for r in records}
    missing = [key for key in planned if key not in graded]
    if timed_out or crashed or missing:
        why = (f"no answer within {timeout:g} s" if timed_out
               else (err.strip().splitlines() or ["the worker stopped"])[-1])
        kind = "timeout" if timed_out else "internal error"
        for consts, line in missing:
            records.append({"consts": consts, "line": line, "property": _line_text(run.props, line),
                            "expected": "?", "class": kind, "actual": "-", "message": why})
        if not planned and not records:  # ended before it knew its lines
            records.append({"consts": "", "line": 0, "property": "(whole file)",
                            "expected": "?", "class": kind, "actual": "-", "message": why})
    rel = {"folder": run.folder, "model": str(Path(run.model).relative_to(tests)),
           "props": str(Path(run.props).relative_to(tests)), "args": run.args_text}
    for r in records:
        why = DELIBERATE.get((rel["props"], r["line"]))
        if (why and r["class"] == "wrong answer" and r["expected"].startswith("Error")
                and r.get("sound")):
            r["class"], r["message"] = "deliberate difference", why
    return [{**rel, **r} for r in records], seconds


def _line_text(path: str, line: int) -> str:
    try:
        return Path(path).read_text(errors="replace").splitlines()[line - 1].strip()
    except IndexError:
        return ""


def _count_results(path: str) -> int:
    return len(re.findall(r"RESULT[^:\n]*:", Path(path).read_text(errors="replace")))


# refusal features: the first pattern that matches the property's text names it
FEATURES: tuple[tuple[str, str], ...] = (
    ("multi-objective multi(...)", r"\bmulti\s*\("),
    ("filter(op, prop, states)", r"\bfilter\s*\("),
    ("old {states}{min} filter form", r"\]\s*\{[^}]*\}\s*\{"),
    ("CTL A[...] / E[...]", r"(^|[^\w])[AE]\s*\["),
    ("steady state S / R[S]", r"(^|[^\w])S\s*(=\s*\?|[<>]=?)|\[\s*S\s*\]"),
    (
        "non-co-safe LTL (G F, F G, ...)",
        r"\bG\s*\(?\s*F\b|\bF\s*\(?\s*G\b|\bG\s*!?\s*\(?\s*\"|\bG\s*\(",
    ),
    ("power operator ^", r"\^"),
    ("property reference by name", r"^\s*\"[^\"]+\"\s*$|[^:]\s\"[^\"]+\"\s*[;)|&]"),
)


# what the message says decides first (a filter around non-co-safe LTL is refused for the LTL)
MESSAGE_FEATURES: tuple[tuple[str, str], ...] = (
    ("non-co-safe LTL (G F, F G, ...)", "not co-safe"),
    ("LTL under A[...] / E[...]", "is checked for CTL path formulas only"),
    ("exact mode (--exact) beyond what it answers", "exact mode answers"),
)


def _feature(record: dict[str, Any]) -> str:
    message = record.get("message", "") or ""
    for name, words in MESSAGE_FEATURES:
        if words in message:
            return name
    text = record.get("property", "")
    for name, pattern in FEATURES:
        if re.search(pattern, text):
            return name
    return "other"


def _first_line(message: str) -> str:
    for line in message.splitlines():
        if "error:" in line:
            return line.split("error:", 1)[1].strip()
    return (message.splitlines() or [""])[0].strip()


def markdown(records: list[dict[str, Any]], skipped: list[tuple[Run, int]], *, command: str,
             seconds: float) -> str:
    """docs/compatibility.md's generated part: the table, the wrong answers, the refusals."""
    by_folder: dict[str, Counter[str]] = defaultdict(Counter)
    for r in records:
        top = r["folder"] if r["folder"].count("/") < 3 else "/".join(r["folder"].split("/")[:3])
        by_folder[top][r["class"]] += 1
    total = Counter(r["class"] for r in records)
    lines = [
        f"Command: `{command}`  ",
        (f"Date: {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; machine: "
         f"{platform.node()} ({os.cpu_count()} cores, shared with other jobs), Python "
         f"{platform.python_version()}; {seconds:.0f} s in all."),
        "",
        "| folder | graded | " + " | ".join(CLASSES) + " |",
        "|---|---:|" + "---:|" * len(CLASSES),
    ]
    for folder in sorted(by_folder):
        c = by_folder[folder]
        lines.append(
            f"| {folder} | {sum(c.values())} | " + " | ".join(str(c[k]) for k in CLASSES) + " |"
        )
    n = sum(total.values())
    lines.append(f"| **all** | **{n}** | " + " | ".join(f"**{total[k]}**" for k in CLASSES) + " |")
    if n:
        lines += ["", f"{100 * total['pass'] / n:.1f} % of the graded lines pass."]
    wrong = [r for r in records if r["class"] == "wrong answer"]
    lines += ["", "### Wrong answers", ""]
    if not wrong:
        lines.append("None.")
    for r in wrong:
        lines.append(
            f"- `{r['props']}:{r['line']}` `{r['property']}`"
            f"{' (' + r['consts'] + ')' if r['consts'] else ''}"
            f"{' ' + r['args'] if r['args'] else ''}:"
            f" PRISM {r['expected']}, posgmc {r['actual']}"
        )
    deliberate = [r for r in records if r["class"] == "deliberate difference"]
    lines += ["", "### Deliberate differences", ""]
    if not deliberate:
        lines.append("None.")
    for r in deliberate:
        lines.append(f"- `{r['props']}:{r['line']}` `{r['property']}`: PRISM {r['expected']}, "
                     f"posgmc {r['actual']} — {r['message']}")
    lines += ["", "### Refusals by feature", "",
              ("Each line: how many graded lines, then the message a user sees (first line) and "
               "one example."), ""]
    refusals = [r for r in records
                if r["class"] not in ("pass", "wrong answer", "deliberate difference")]
    groups: dict[str, dict[str, list[dict[str, Any]]]] = defaultdict(lambda: defaultdict(list))
    for r in refusals:
        groups[f"{_feature(r)} ({r['class']})"][_first_line(r.get("message", ""))].append(r)
    for feature in sorted(groups, key=lambda f: -sum(len(v) for v in groups[f].values())):
        count = sum(len(v) for v in groups[feature].values())
        lines.append(f"- **{feature}**: {count}")
        for message, rs in sorted(groups[feature].items(), key=lambda kv: -len(kv[1])):
            ex = rs[0]
            lines.append(f"  - {len(rs)} × “{message}” — e.g. `{ex['props']}:{ex['line']}` "
                         f"`{ex['property'][:90]}`")
    lines += ["", "### Out of scope (not run)", "",
              "| reason | runs | RESULT lines in those files |", "|---|---:|---:|"]
    reasons: dict[str, list[int]] = defaultdict(lambda: [0, 0])
    for run, count in skipped:
        key = re.sub(r" on a \w+$", "", run.skip or "")
        reasons[key][0] += 1
        reasons[key][1] += count
    for reason, (runs, count) in sorted(reasons.items(), key=lambda kv: -kv[1][1]):
        lines.append(f"| {reason} | {runs} | {count} |")
    return "\n".join(lines) + "\n"


_BEGIN = "<!-- prism_suite.py: begin -->"
_END = "<!-- prism_suite.py: end -->"


def _write_markdown(path: Path, body: str) -> None:
    """Replace the generated part of ``path`` (between the markers), keeping the rest."""
    old = path.read_text() if path.exists() else f"# Compatibility with PRISM\n\n{_BEGIN}\n{_END}\n"
    if _BEGIN not in old:
        old += f"\n{_BEGIN}\n{_END}\n"
    head, rest = old.split(_BEGIN, 1)
    tail = rest.split(_END, 1)[1] if _END in rest else "\n"
    path.write_text(f"{head}{_BEGIN}\n{body}{_END}{tail}")


def _tests_root(path: Path) -> Path:
    for candidate in (path / "prism-tests", path, path.parent / "prism-tests"):
        if (candidate / "functionality" / "verify").is_dir():
            return candidate
    raise SystemExit(f"{path}: no prism-tests/functionality/verify below it (a PRISM checkout?)")


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("prism", type=Path, help="a PRISM checkout (or its prism-tests folder)")
    ap.add_argument("--timeout", type=float, default=60.0, help="seconds per run")
    ap.add_argument("--json", type=Path, default=None, help="also write every graded line here")
    ap.add_argument("--markdown", type=Path, default=None,
                    help="rewrite the generated part of this file (docs/compatibility.md)")
    ap.add_argument("--only", default=None, help="only runs whose properties path contains this")
    ap.add_argument("--quiet", action="store_true")
    ap.add_argument("--from-json", type=Path, default=None,
                    help="rewrite --markdown from an earlier run's --json instead of running")
    opts = ap.parse_args(argv)
    tests = _tests_root(opts.prism.resolve())
    runs = discover(tests)
    if opts.only:
        runs = [r for r in runs if opts.only in r.props]
    started = time.perf_counter()
    records: list[dict[str, Any]] = []
    skipped: list[tuple[Run, int]] = []
    earlier: float | None = None
    if opts.from_json is not None:
        saved = json.loads(opts.from_json.read_text())
        records, earlier = (saved, None) if isinstance(saved, list) else (
            saved["records"], saved.get("seconds"))
    for k, run in enumerate(runs, 1):
        if run.skip:
            skipped.append((run, _count_results(run.props)))
            continue
        if opts.from_json is not None:
            continue
        got, seconds = _run_one(run, tests, opts.timeout)
        records += got
        if not opts.quiet:
            c = Counter(r["class"] for r in got)
            print(f"[{k}/{len(runs)}] {Path(run.props).relative_to(tests)} {run.args_text} "
                  f"{seconds:.1f}s {dict(c)}", file=sys.stderr, flush=True)
    seconds = time.perf_counter() - started if opts.from_json is None else (earlier or 0.0)
    total = Counter(r["class"] for r in records)
    print(json.dumps({k: total[k] for k in CLASSES}))
    if opts.json:
        opts.json.write_text(json.dumps({"seconds": seconds, "records": records}, indent=1))
    if opts.markdown:
        given = list(argv if argv is not None else sys.argv[1:])[1:]
        valued = ("--json", "--from-json")
        shown = [a for i, a in enumerate(given)
                 if a not in valued and (i == 0 or given[i - 1] not in valued)]
        command = "python benchmarks/prism_suite.py PRISM_CHECKOUT " + " ".join(shown)
        _write_markdown(opts.markdown, markdown(records, skipped, command=command.strip(),
                                                seconds=seconds))
    return 0


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--worker":
        worker(json.loads(sys.argv[2]))
        sys.exit(0)
    sys.exit(main())
