"""Print syntax trees back as PRISM text, with exactly the parentheses the grammar needs.

``parse_expression(format_expr(e)) == e`` for every expression the parser can produce (spans
aside); the tests check this with hypothesis. Two representation limits: a ``DoubleLit`` whose
value has no finite decimal expansion prints as a division ``(1/3)``, and negative literals
(which only later passes create) print as a unary minus.
"""

from __future__ import annotations

from fractions import Fraction

from posgmc.syntax.ast import (
    Binary,
    BinaryOp,
    BoolLit,
    Call,
    Coalition,
    CoalitionKind,
    DoubleLit,
    Expr,
    Filter,
    Ident,
    IntLit,
    Ite,
    LabelRef,
    MultiQuery,
    PathQuantifier,
    ProbQuery,
    RewardKind,
    RewardObjective,
    RewardQuery,
    SteadyQuery,
    Temporal,
    TemporalOp,
    Threshold,
    TimeBound,
    Unary,
    UnaryOp,
)

__all__ = ["format_expr", "format_coalition", "format_objective", "format_decimal"]

# Precedence levels, loosest first (mirrors grammar/prism.lark).
_PATH_BINARY = 0  # a U b, a W b, a R b (not associative)
_PATH_UNARY = 1  # X a, F a, G a
_ITE = 2
_IMPLIES = 3
_IFF = 4
_OR = 5
_AND = 6
_NOT = 7
_EQ = 8
_REL = 9
_SUM = 10
_PROD = 11
_NEG = 12
_ATOM = 13

_BINARY_LEVEL: dict[BinaryOp, int] = {
    BinaryOp.IMPLIES: _IMPLIES,
    BinaryOp.IFF: _IFF,
    BinaryOp.OR: _OR,
    BinaryOp.AND: _AND,
    BinaryOp.EQ: _EQ,
    BinaryOp.NE: _EQ,
    BinaryOp.LT: _REL,
    BinaryOp.LE: _REL,
    BinaryOp.GT: _REL,
    BinaryOp.GE: _REL,
    BinaryOp.ADD: _SUM,
    BinaryOp.SUB: _SUM,
    BinaryOp.MUL: _PROD,
    BinaryOp.DIV: _PROD,
}


def format_expr(expr: Expr) -> str:
    """PRISM text for ``expr`` (model expression, state or path formula, or query).

    Args:
        expr: any expression node.

    Returns:
        Text that parses back to an equal tree (``parse_expression``), parenthesised only
        where precedence requires it (plus around the operand of ``!`` when it is a binary
        operation, for readability).
    """
    return _fmt(expr, _PATH_BINARY)


def format_decimal(value: Fraction) -> str:
    """A non-negative fraction as a decimal literal (``0.1``, ``3.0``), or ``(p/q)`` when it has
    no finite decimal expansion."""
    if value < 0:
        raise ValueError("format_decimal expects a non-negative value")
    den = value.denominator
    twos = fives = 0
    while den % 2 == 0:
        den //= 2
        twos += 1
    while den % 5 == 0:
        den //= 5
        fives += 1
    if den != 1:
        return f"({value.numerator}/{value.denominator})"
    digits = max(twos, fives, 1)
    scaled = value.numerator * 10**digits // value.denominator
    whole, frac = divmod(scaled, 10**digits)
    return f"{whole}.{frac:0{digits}d}"


def format_coalition(coalition: Coalition) -> str:
    """``<<p1,2>>``, ``<<*>>`` or ``[[p1]]``."""
    if coalition.all_players:
        inner = "*"
    else:
        inner = ",".join(
            p.name if p.name is not None else str(p.number) for p in coalition.players
        )
    if coalition.kind is CoalitionKind.BRACKET:
        return f"[[{inner}]]"
    return f"<<{inner}>>"


def format_objective(objective: RewardObjective) -> str:
    """The text between the brackets of an ``R`` query (``F "goal"``, ``C<=10``, ...)."""
    kind = objective.kind
    if kind is RewardKind.REACH:
        return "F " + _operand(_required(objective.target))
    if kind is RewardKind.REACH_ZERO:
        return "F0 " + _fmt(_required(objective.target), _ITE)
    if kind is RewardKind.REACH_CUMULATIVE:
        return "Fc " + _fmt(_required(objective.target), _ITE)
    if kind is RewardKind.CUMULATIVE:
        return "C<=" + _fmt(_required(objective.bound), _ITE)
    if kind is RewardKind.TOTAL:
        return "C"
    if kind is RewardKind.STEADY:
        return "S"
    if kind is RewardKind.INSTANTANEOUS:
        return "I=" + _fmt(_required(objective.bound), _ITE)
    if kind is RewardKind.DISCOUNTED_TOTAL:
        return "Cdiscount=" + _fmt(_required(objective.discount), _ITE)
    if kind is RewardKind.DISCOUNTED_REACH:
        discount = _fmt(_required(objective.discount), _PROD)
        return f"Fdiscount={discount} " + _fmt(_required(objective.target), _ITE)
    return _fmt(_required(objective.target), _PATH_BINARY)


def _required(expr: Expr | None) -> Expr:
    if expr is None:
        raise ValueError("reward objective is missing a required expression")
    return expr


def _level(expr: Expr) -> int:
    if isinstance(expr, Temporal):
        return _PATH_UNARY if len(expr.operands) == 1 else _PATH_BINARY
    if isinstance(expr, Ite):
        return _ITE
    if isinstance(expr, Binary):
        return _BINARY_LEVEL[expr.op]
    if isinstance(expr, Unary):
        return _NOT if expr.op is UnaryOp.NOT else _NEG
    if isinstance(expr, IntLit) and expr.value < 0:
        return _NEG
    if isinstance(expr, DoubleLit) and expr.value < 0:
        return _NEG
    return _ATOM


def _fmt(expr: Expr, minimum: int) -> str:
    """``expr`` as text that parses at precedence level ``minimum`` or tighter."""
    text = _bare(expr)
    if _level(expr) < minimum:
        return f"({text})"
    return text


def _bare(expr: Expr) -> str:
    if isinstance(expr, IntLit):
        return str(expr.value)
    if isinstance(expr, DoubleLit):
        if expr.value < 0:
            return "-" + format_decimal(-expr.value)
        return format_decimal(expr.value)
    if isinstance(expr, BoolLit):
        return "true" if expr.value else "false"
    if isinstance(expr, Ident):
        return expr.name
    if isinstance(expr, LabelRef):
        return f'"{expr.name}"'
    if isinstance(expr, Unary):
        if expr.op is UnaryOp.NOT:
            operand = expr.operand
            inner = _fmt(operand, _NOT)
            if isinstance(operand, Binary) and _level(operand) >= _NOT:
                inner = f"({inner})"  # `!a = b` means !(a = b); say so
            return "!" + inner
        inner = _fmt(expr.operand, _NEG)
        if inner.startswith("-"):
            inner = f"({inner})"
        return "-" + inner
    if isinstance(expr, Binary):
        level = _BINARY_LEVEL[expr.op]
        if expr.op is BinaryOp.IMPLIES:  # right associative
            left, right = _fmt(expr.left, level + 1), _fmt(expr.right, level)
        else:
            left, right = _fmt(expr.left, level), _fmt(expr.right, level + 1)
        return f"{left} {expr.op.value} {right}"
    if isinstance(expr, Ite):
        cond = _fmt(expr.cond, _IMPLIES)
        then = _fmt(expr.then, _IMPLIES)
        otherwise = _fmt(expr.otherwise, _ITE)
        return f"{cond} ? {then} : {otherwise}"
    if isinstance(expr, Call):
        args = ", ".join(_fmt(a, _ITE) for a in expr.args)
        return f"{expr.function.value}({args})"
    if isinstance(expr, Filter):
        # the old form P=? [ ... {states}{min} ] prints as the filter it means
        states = f", {_fmt(expr.states, _ITE)}" if expr.states is not None else ""
        return f"filter({expr.op.value}, {_fmt(expr.operand, _ITE)}{states})"
    if isinstance(expr, SteadyQuery):
        op = _operator("S", None, None, expr.threshold)
        return f"{op} [ {_fmt(expr.operand, _ITE)} ]"
    if isinstance(expr, PathQuantifier):
        return f"{'A' if expr.universal else 'E'} [ {_fmt(expr.path, _PATH_BINARY)} ]"
    if isinstance(expr, Temporal):
        return _temporal(expr)
    if isinstance(expr, MultiQuery):
        if expr.coalition is not None:
            body = " & ".join(_fmt(o, _ITE) for o in expr.objectives)
            return f"{format_coalition(expr.coalition)} ({body})"
        return "multi(" + ", ".join(_fmt(o, _ITE) for o in expr.objectives) + ")"
    if isinstance(expr, ProbQuery):
        prefix = format_coalition(expr.coalition) + " " if expr.coalition else ""
        op = _operator("P", None, expr.direction, expr.threshold)
        return f"{prefix}{op} [ {_fmt(expr.path, _PATH_BINARY)} ]"
    if isinstance(expr, RewardQuery):
        prefix = format_coalition(expr.coalition) + " " if expr.coalition else ""
        op = _operator("R", expr.reward, expr.direction, expr.threshold)
        return f"{prefix}{op} [ {format_objective(expr.objective)} ]"
    raise TypeError(f"cannot print {type(expr).__name__}")


def _operator(
    letter: str, reward: str | int | None, direction: object, threshold: Threshold | None
) -> str:
    index = ""
    if isinstance(reward, str):
        index = f'{{"{reward}"}}'
    elif isinstance(reward, int):
        index = f"{{{reward}}}"
    if threshold is not None:
        return f"{letter}{index}{threshold.op.value}{_fmt(threshold.value, _ITE)}"
    if direction is None:
        return f"{letter}{index}=?"
    word = getattr(direction, "value", str(direction))
    return f"{letter}{index}{word}=?"


def _bound(bound: TimeBound | None) -> str:
    if bound is None:
        return ""
    lower, upper = bound.lower, bound.upper
    if lower is not None and upper is not None:
        if lower == upper and not bound.lower_strict and not bound.upper_strict:
            return "=" + _fmt(lower, _PROD)
        return f"[{_fmt(lower, _ITE)},{_fmt(upper, _ITE)}]"
    if upper is not None:
        return ("<" if bound.upper_strict else "<=") + _fmt(upper, _PROD)
    if lower is not None:
        return (">" if bound.lower_strict else ">=") + _fmt(lower, _PROD)
    return ""


def _operand(expr: Expr) -> str:
    # Operands of temporal operators bind loosely (`F a & b` is `F (a & b)`), which readers
    # rarely expect: parenthesise compound ones even where the grammar would not need it.
    if isinstance(expr, (Binary, Ite)):
        return f"({_bare(expr)})"
    return _fmt(expr, _PATH_UNARY)


def _temporal(expr: Temporal) -> str:
    bound = _bound(expr.bound)
    if len(expr.operands) == 1:
        return f"{expr.op.value}{bound} {_operand(expr.operands[0])}"
    left, right = expr.operands
    if expr.op not in (TemporalOp.UNTIL, TemporalOp.WEAK_UNTIL, TemporalOp.RELEASE):
        raise ValueError(f"{expr.op.value} takes one operand")
    return f"{_operand(left)} {expr.op.value}{bound} {_operand(right)}"
