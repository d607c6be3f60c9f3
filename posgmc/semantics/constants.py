"""Constants: the user's ``--const`` settings, and the values of every declared constant.

Rules (PRISM's ``ConstantList``/``UndefinedConstants``):

* Constants are evaluated in dependency order, whatever their order in the file; a cycle
  (``const a = b; const b = a;``) is an error at the first constant of the cycle.
* ``const int N;`` (no value) is *undefined*: the user gives its value (``--const N=4``). Giving a
  value to a name that is not a constant of the files is an error, and so is giving one to a
  constant the file already defines.
* Given values are converted to the declared type: an int may be given to a double; a double (or
  ``"0.5"``) to an int is an error, as is a number to a bool (``true``/``false`` only).
* An int constant *defined* by a double expression (``const r = N/2;``) is accepted when the value
  is a whole number: Storm types ``N/2`` as an int and PAYNT's models rely on it (``rocks-12``);
  PRISM would reject the definition. Other double values are errors.
* Doubles stay exact: ``"0.9"`` is ``Fraction(9, 10)``; a Python ``float`` is read through its
  shortest repr (``0.9`` -> ``9/10``, what the user typed).
* Ranges (``N=1:1:5``, ``k=0:5``: start[:step]:stop, stop included) describe a sweep, expanded by
  :func:`expand_sweep` into one setting per combination.
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction

from posgmc.errors import ConstantError, PosgmcError, SourceSpan
from posgmc.semantics.evaluate import Value, evaluate, format_value, free_names, to_double
from posgmc.semantics.symbols import span_or_none
from posgmc.syntax.ast import INT64_MAX, INT64_MIN, ConstantDecl, Expr, VarType

__all__ = [
    "ConstRange",
    "ConstSetting",
    "ConstantValues",
    "UserConstant",
    "convert_user_value",
    "expand_sweep",
    "find_cycles",
    "parse_const_assignments",
    "resolve_constants",
]

UserConstant = str | int | float | bool | Fraction
"""A value as a user may give it: text as on the command line, or a Python value."""


@dataclass(frozen=True)
class ConstSetting:
    """A value given by the user for an undefined constant, with where it was given (the span
    into the ``--const`` text), so that errors about it can point there."""

    value: UserConstant
    span: SourceSpan | None = None


@dataclass(frozen=True)
class ConstRange:
    """``start:stop`` or ``start:step:stop`` (stop included), as given to ``--const``."""

    start: str
    stop: str
    step: str = "1"
    span: SourceSpan | None = None

    def values(self) -> tuple[int | Fraction, ...]:
        """The values of the range: ints when start, step and stop are all integers.

        Raises:
            ConstantError: malformed numbers, a zero step, or an empty range.
        """
        parts = []
        for text in (self.start, self.step, self.stop):
            try:
                parts.append(_parse_number(text))
            except ValueError:
                raise ConstantError(
                    f'"{text}" is not a number in the range {self._text()}', self.span
                ) from None
        start, step, stop = parts
        if step == 0:
            raise ConstantError(f"the step of the range {self._text()} is zero", self.span)
        all_int = all(isinstance(p, int) for p in parts)
        out: list[int | Fraction] = []
        v: int | Fraction = start
        while (step > 0 and v <= stop) or (step < 0 and v >= stop):
            out.append(v if all_int else Fraction(v))
            v = v + step
            if len(out) > 1_000_000:
                raise ConstantError(f"the range {self._text()} has too many values", self.span)
        if not out:
            raise ConstantError(f"the range {self._text()} is empty", self.span)
        return tuple(out)

    def _text(self) -> str:
        return f"{self.start}:{self.step}:{self.stop}"


_INT_RE = re.compile(r"[+-]?\d+")
_NAME_RE = re.compile(r"[A-Za-z_][A-Za-z_0-9]*")


def _parse_number(text: str) -> int | Fraction:
    text = text.strip()
    if len(text) > 400:  # Python converts at most 4300 digits; no sane constant is this long
        raise ValueError(f"{text[:20]}... has too many digits")
    if _INT_RE.fullmatch(text):
        return int(text)
    return Fraction(text)  # "0.5", "1e-3", "1/3"; ValueError otherwise


def parse_const_assignments(
    text: str, *, source: str = "--const"
) -> dict[str, ConstSetting | ConstRange]:
    """Parse ``N=4,p=0.9,k=0:5,M=1:2:9`` (PRISM's ``-const`` syntax).

    Args:
        text: the option's text.
        source: what to call the text in error positions (the span's file).

    Returns:
        name -> :class:`ConstSetting` (single value, kept as text: the type is the declaration's)
        or :class:`ConstRange`, in the order given.

    Raises:
        ConstantError: a part without ``name=value``, a bad name, or a name given twice.
    """
    out: dict[str, ConstSetting | ConstRange] = {}
    pos = 0
    for part in text.split(","):
        col = pos + 1
        pos += len(part) + 1
        if not part.strip():
            continue
        span = SourceSpan(1, col, 1, col + len(part), source)
        name, eq, value = part.partition("=")
        name, value = name.strip(), value.strip()
        if not eq or not value:
            raise ConstantError(
                f'"{part}" is not of the form name=value', span, hint="e.g. --const N=4,p=0.9,k=0:5"
            )
        if not _NAME_RE.fullmatch(name):
            raise ConstantError(f'"{name}" is not a constant name', span)
        if name in out:
            raise ConstantError(f'constant "{name}" is given a value twice', span)
        if ":" in value:
            pieces = [p.strip() for p in value.split(":")]
            if len(pieces) == 2 and all(pieces):
                out[name] = ConstRange(pieces[0], pieces[1], "1", span)
            elif len(pieces) == 3 and all(pieces):
                out[name] = ConstRange(pieces[0], pieces[2], pieces[1], span)
            else:
                raise ConstantError(
                    f'"{value}" is not a range start:stop or start:step:stop', span
                )
        else:
            out[name] = ConstSetting(value, span)
    return out


def expand_sweep(
    settings: Mapping[str, ConstSetting | ConstRange | UserConstant],
) -> list[dict[str, ConstSetting | UserConstant]]:
    """One setting per combination of the ranges in ``settings`` (the last range varies
    fastest); single values are kept as they are.

    Raises:
        ConstantError: a malformed range.
    """
    names = list(settings)
    axes: list[list[ConstSetting | UserConstant]] = []
    for name in names:
        v = settings[name]
        if isinstance(v, ConstRange):
            axes.append([ConstSetting(x, v.span) for x in v.values()])
        else:
            axes.append([v])
    return [dict(zip(names, combo)) for combo in itertools.product(*axes)]


def convert_user_value(
    name: str, var_type: VarType, given: object, *, span: SourceSpan | None = None
) -> Value:
    """Convert a user-given value to the declared type of constant ``name``.

    Args:
        name: the constant.
        var_type: its declared type.
        given: text (``"4"``, ``"0.9"``, ``"true"``), a Python value, or a :class:`ConstSetting`.
        span: where to point errors when ``given`` carries no span of its own.

    Returns:
        The value (int, Fraction or bool).

    Raises:
        ConstantError: the value does not fit the type (see the module docstring).
    """
    if isinstance(given, ConstSetting):
        return convert_user_value(name, var_type, given.value, span=given.span or span)
    if isinstance(given, ConstRange):
        raise ConstantError(
            f'constant "{name}" is given a range; expand it first (expand_sweep)', span
        )
    shown = f'"{given}"' if isinstance(given, str) else repr(given)
    if isinstance(given, str) and not _is_literal(given):
        # PRISM accepts a constant expression as the value: --const p=1/3, N=2*3
        computed = _expression_value(given)
        if computed is not None:
            given = computed
            shown = f"{shown} (= {computed})"
    if var_type is VarType.BOOL:
        if isinstance(given, bool):
            return given
        if isinstance(given, str) and given.strip() in ("true", "false"):
            return given.strip() == "true"
        raise ConstantError(
            f'constant "{name}" is a bool, but {shown} is not true or false', span
        )
    if isinstance(given, bool):
        raise ConstantError(f'constant "{name}" is {_a(var_type)}, but {shown} is a Boolean', span)
    if var_type is VarType.INT:
        value: int | None = None
        if isinstance(given, int):
            value = given
        elif isinstance(given, str) and _INT_RE.fullmatch(given.strip()):
            value = int(given.strip()) if len(given.strip()) <= 30 else INT64_MAX + 1
        if value is not None:
            if not INT64_MIN <= value <= INT64_MAX:
                raise ConstantError(
                    f'constant "{name}" is an int, but {shown} is beyond 64-bit integers',
                    span,
                    hint=f'declare it "const double {name};" if an approximate value will do',
                )
            return value
        raise ConstantError(
            f'constant "{name}" is an int, but {shown} is not an integer',
            span,
            hint=f'declare it "const double {name};" if it is not a whole number',
        )
    # double
    if isinstance(given, (int, Fraction)):
        return to_double(given)
    if isinstance(given, float):
        try:
            return Fraction(repr(given))
        except ValueError:  # inf / nan
            msg = f'constant "{name}" is given the non-finite value {shown}'
            raise ConstantError(msg, span) from None
    if isinstance(given, str):
        try:
            return to_double(_parse_number(given))
        except (ValueError, ZeroDivisionError):
            pass
    raise ConstantError(f'constant "{name}" is a double, but {shown} is not a number', span)


def _is_literal(text: str) -> bool:
    t = text.strip()
    if t in ("true", "false") or _INT_RE.fullmatch(t):
        return True
    try:
        _parse_number(t)
    except (ValueError, ZeroDivisionError):
        return False
    return True


def _expression_value(text: str) -> int | Fraction | bool | None:
    """The value of a constant expression written as a constant's value, or None when the text
    is not one (the caller then reports the value as it was given)."""
    from posgmc.errors import PosgmcError
    from posgmc.semantics.evaluate import evaluate_constant
    from posgmc.syntax.parser import parse_expression

    try:
        value = evaluate_constant(parse_expression(text, model=True))
    except PosgmcError:
        return None
    if isinstance(value, float):
        try:
            return Fraction(repr(value))
        except ValueError:
            return None
    return value


def _a(t: VarType) -> str:
    return "an int" if t is VarType.INT else f"a {t.value}"


@dataclass(frozen=True)
class ConstantValues:
    """The outcome of :func:`resolve_constants`.

    ``values``: every constant whose value is known, by name (ints as int, doubles as Fraction or
    float, bools as bool). ``undefined``: declarations without a value that the user did not give
    one, in source order. ``unknown``: every constant without a known value (undefined ones, those
    that depend on them, those in a cycle or whose evaluation failed).
    """

    values: Mapping[str, Value]
    undefined: tuple[ConstantDecl, ...] = ()
    unknown: frozenset[str] = field(default_factory=frozenset)


def resolve_constants(
    decls: Sequence[ConstantDecl],
    *,
    settings: Mapping[str, object],
    errors: list[PosgmcError],
    base: ConstantValues | None = None,
) -> ConstantValues:
    """Evaluate the declared constants in dependency order.

    Args:
        decls: the declarations, values with formulas already inlined; a name declared twice is
            reported elsewhere, the first declaration counts.
        settings: user values by name (text, Python values or :class:`ConstSetting`); names that
            are not among ``decls`` are ignored here (the caller reports unknown names).
        errors: where cycles, bad user values, user values for defined constants and evaluation
            failures are appended.
        base: constants already known (the model's, when resolving a properties file).

    Returns:
        The values; see :class:`ConstantValues`.
    """
    by_name: dict[str, ConstantDecl] = {}
    for d in decls:
        by_name.setdefault(d.name, d)
    values: dict[str, Value] = dict(base.values) if base else {}
    unknown: set[str] = set(base.unknown) if base else set()
    undefined: list[ConstantDecl] = []

    deps = {
        name: sorted(free_names(d.value) & by_name.keys(), key=lambda n: _pos(by_name[n]))
        if d.value is not None
        else []
        for name, d in by_name.items()
    }
    cyclic = _report_cycles(by_name, deps, errors)
    unknown |= cyclic

    state: dict[str, int] = {}  # 1: visiting, 2: done

    def visit(name: str) -> None:
        if state.get(name) or name in cyclic:
            return
        state[name] = 1
        for dep in deps[name]:
            visit(dep)
        state[name] = 2
        decl = by_name[name]
        given = settings.get(name)
        if decl.value is None:
            if given is None:
                undefined.append(decl)
                unknown.add(name)
                return
            try:
                # a plain value has no position of its own: point at the declaration instead
                values[name] = convert_user_value(
                    name, decl.type, given, span=span_or_none(decl.span)
                )
            except ConstantError as err:
                errors.append(err)
                unknown.add(name)
            return
        if given is not None:
            span = given.span if isinstance(given, (ConstSetting, ConstRange)) else None
            span = span or span_or_none(decl.span)
            errors.append(
                ConstantError(
                    f'constant "{name}" is already defined in the file, so it cannot be given '
                    "a value",
                    span,
                    hint=f'only constants declared without a value (e.g. "const int {name};") '
                    "take values from --const",
                )
            )
        if any(dep in unknown for dep in deps[name]) or _refers_to_unknown(decl.value, values):
            unknown.add(name)
            return
        try:
            v = evaluate(decl.value, values)
        except PosgmcError as err:
            errors.append(err)
            unknown.add(name)
            return
        if decl.type is VarType.INT and not isinstance(v, (bool, int)):
            # Storm types int/int as int, so PAYNT models write "const r = N/2;" for an int
            # constant; PRISM's types make N/2 a double. Accept a double value that is a whole
            # number (rocks-12), reject others.
            if isinstance(v, float) and not math.isfinite(v) or v != int(v):
                errors.append(
                    ConstantError(
                        f'int constant "{name}" has the value {format_value(v)}, which is not '
                        "a whole number",
                        span_or_none(decl.value.span),
                        hint=f'declare it "const double {name} = ...;" or round the value',
                    )
                )
                unknown.add(name)
                return
            v = int(v)
            if not INT64_MIN <= v <= INT64_MAX:
                errors.append(
                    ConstantError(
                        f'int constant "{name}" has the value {format_value(v)}, beyond 64-bit '
                        "integers",
                        span_or_none(decl.value.span),
                    )
                )
                unknown.add(name)
                return
        values[name] = _cast(v, decl.type)

    for d in sorted(by_name.values(), key=_pos):
        visit(d.name)
    return ConstantValues(values, tuple(sorted(undefined, key=_pos)), frozenset(unknown))


def _refers_to_unknown(expr: Expr, values: Mapping[str, Value]) -> bool:
    # names that are neither known constants nor declared ones (undefined names, variables):
    # reported by the type checker; here they just make the value unknown
    return any(n not in values for n in free_names(expr))


def _cast(v: Value, t: VarType) -> Value:
    if t is VarType.DOUBLE and isinstance(v, int) and not isinstance(v, bool):
        return Fraction(v)
    return v


def _pos(d: ConstantDecl) -> tuple[int, int]:
    return (d.span.line, d.span.column)


def _report_cycles(
    by_name: Mapping[str, ConstantDecl], deps: Mapping[str, list[str]], errors: list[PosgmcError]
) -> set[str]:
    """Report each cycle once, at its first constant in source order; return every constant on
    a cycle."""
    order = sorted(by_name, key=lambda n: _pos(by_name[n]))
    cyclic: set[str] = set()
    for path in find_cycles(order, deps):
        cyclic.update(path)
        errors.append(
            ConstantError(
                f'cyclic definition of constant "{path[0]}" ({" -> ".join(path)})',
                span_or_none(by_name[path[0]].span),
            )
        )
    return cyclic


def find_cycles(order: Sequence[str], deps: Mapping[str, Sequence[str]]) -> list[list[str]]:
    """The cyclic strongly connected components of a dependency graph (Tarjan), one cycle each.

    Args:
        order: the nodes, in the order that decides which node of a cycle is named first
            (source order).
        deps: node -> the nodes it depends on (nodes outside ``order`` are ignored).

    Returns:
        For each component with a cycle: a cycle through its earliest node ``v``, as
        ``[v, ..., v]``.
    """
    rank = {v: i for i, v in enumerate(order)}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    counter = 0

    def succ(v: str) -> list[str]:
        return [w for w in deps.get(v, ()) if w in rank]

    def strong(v: str) -> None:
        nonlocal counter
        index[v] = low[v] = counter
        counter += 1
        stack.append(v)
        on_stack.add(v)
        for w in succ(v):
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp: list[str] = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1 or v in succ(v):
                first = min(comp, key=lambda n: rank[n])
                found.append(_cycle_path(first, set(comp), succ))

    for v in order:
        if v not in index:
            strong(v)
    found.sort(key=lambda p: rank[p[0]])
    return found


def _cycle_path(start: str, comp: set[str], succ: Callable[[str], list[str]]) -> list[str]:
    """A cycle through ``start`` inside its component, as a list of names ending in ``start``."""
    # breadth-first search from start's successors back to start
    prev: dict[str, str] = {}
    frontier = [start]
    seen = {start}
    while frontier:
        nxt: list[str] = []
        for v in frontier:
            for w in succ(v):
                if w not in comp:
                    continue
                if w == start:
                    path = [v]
                    while path[-1] != start:
                        path.append(prev[path[-1]])
                    return [start] + list(reversed(path[:-1])) + [start]
                if w not in seen:
                    seen.add(w)
                    prev[w] = v
                    nxt.append(w)
        frontier = nxt
    return [start, start]
