"""Hand-built FlatModels for the compiler's tests, written compactly.

``ex("x < N-1 and not done", N=4, done="x = 3")`` turns a Python-syntax expression into a
posgmc expression tree (``and``/``or``/``not``, ``==``/``!=``/comparisons, ``+ - * /``,
``c if a else b`` for ``a ? c : b``, ``min``/``max``/``floor``/``ceil``/``round``/``pow``/``mod``/
``log``, ``implies(a, b)``, ``iff(a, b)``); keyword arguments substitute names by constants or
by other expressions (formulas). Floats become exact decimal literals.
"""

from __future__ import annotations

import ast
from fractions import Fraction
from typing import Any

from posgmc.errors import SourceSpan
from posgmc.semantics.flat import (
    FlatAssignment,
    FlatCommand,
    FlatModel,
    FlatModule,
    FlatObservable,
    FlatPlayer,
    FlatRewardItem,
    FlatRewardStruct,
    FlatUpdate,
    Variable,
)
from posgmc.syntax import ast as A

_BIN = {
    ast.Add: A.BinaryOp.ADD,
    ast.Sub: A.BinaryOp.SUB,
    ast.Mult: A.BinaryOp.MUL,
    ast.Div: A.BinaryOp.DIV,
}
_CMP = {
    ast.Eq: A.BinaryOp.EQ,
    ast.NotEq: A.BinaryOp.NE,
    ast.Lt: A.BinaryOp.LT,
    ast.LtE: A.BinaryOp.LE,
    ast.Gt: A.BinaryOp.GT,
    ast.GtE: A.BinaryOp.GE,
}
_FUN = {f.value: f for f in A.Function}


def lit(value: Any) -> A.Expr:
    if isinstance(value, A.Expr):
        return value
    if isinstance(value, bool):
        return A.BoolLit(value)
    if isinstance(value, int):
        return A.IntLit(value)
    if isinstance(value, Fraction):
        return A.DoubleLit(value)
    if isinstance(value, float):
        return A.DoubleLit(Fraction(repr(value)))
    if isinstance(value, str):
        return ex(value)
    raise TypeError(value)


def ex(text: str, **env: Any) -> A.Expr:
    """Parse a Python-syntax expression into a posgmc expression (see the module docstring)."""
    tree = ast.parse(text.replace("=>", "<<"), mode="eval").body
    return _conv(
        tree,
        {
            k: (
                ex(v, **{kk: vv for kk, vv in env.items() if kk != k})
                if isinstance(v, str)
                else lit(v)
            )
            for k, v in env.items()
        },
    )


def _conv(n: ast.AST, env: dict[str, A.Expr]) -> A.Expr:
    def c(x: ast.AST) -> A.Expr:
        return _conv(x, env)

    if isinstance(n, ast.Constant):
        return lit(n.value)
    if isinstance(n, ast.Name):
        if n.id in ("true", "false"):
            return A.BoolLit(n.id == "true")
        return env.get(n.id, A.Ident(n.id))
    if isinstance(n, ast.BoolOp):
        op = A.BinaryOp.AND if isinstance(n.op, ast.And) else A.BinaryOp.OR
        out = c(n.values[0])
        for v in n.values[1:]:
            out = A.Binary(op, out, c(v))
        return out
    if isinstance(n, ast.UnaryOp):
        if isinstance(n.op, ast.Not):
            return A.Unary(A.UnaryOp.NOT, c(n.operand))
        if isinstance(n.op, ast.USub):
            return A.Unary(A.UnaryOp.NEG, c(n.operand))
    if isinstance(n, ast.BinOp):
        if isinstance(n.op, ast.LShift):
            return A.Binary(A.BinaryOp.IMPLIES, c(n.left), c(n.right))
        return A.Binary(_BIN[type(n.op)], c(n.left), c(n.right))
    if isinstance(n, ast.Compare):
        out = None
        left = n.left
        for op, right in zip(n.ops, n.comparators):
            part = A.Binary(_CMP[type(op)], c(left), c(right))
            out = part if out is None else A.Binary(A.BinaryOp.AND, out, part)
            left = right
        assert out is not None
        return out
    if isinstance(n, ast.IfExp):
        return A.Ite(c(n.test), c(n.body), c(n.orelse))
    if isinstance(n, ast.Call):
        assert isinstance(n.func, ast.Name)
        name = n.func.id
        args = tuple(c(a) for a in n.args)
        if name == "implies":
            return A.Binary(A.BinaryOp.IMPLIES, *args)
        if name == "iff":
            return A.Binary(A.BinaryOp.IFF, *args)
        return A.Call(_FUN[name], args)
    raise ValueError(f"unsupported syntax: {ast.dump(n)}")


def span(line: int, column: int, end_column: int | None = None) -> SourceSpan:
    return SourceSpan(line, column, line, end_column, "test.prism")


def var(
    name: str,
    low: int,
    high: int,
    init: int | None = None,
    *,
    module: str | None = None,
    sp: SourceSpan | None = None,
) -> Variable:
    return Variable(
        name, A.VarType.INT, low, high, low if init is None else init, module, sp or A.NO_SPAN
    )


def boolvar(
    name: str, init: bool = False, *, module: str | None = None, sp: SourceSpan | None = None
) -> Variable:
    return Variable(name, A.VarType.BOOL, 0, 1, int(init), module, sp or A.NO_SPAN)


def upd(
    prob: Any,
    *assigns: tuple[str, Any],
    sp: SourceSpan | None = None,
    env: dict[str, Any] | None = None,
) -> FlatUpdate:
    env = env or {}
    p = ex(prob, **env) if isinstance(prob, str) else lit(prob)
    return FlatUpdate(
        p,
        tuple(
            FlatAssignment(v, ex(e, **env) if isinstance(e, str) else lit(e)) for v, e in assigns
        ),
        sp or A.NO_SPAN,
    )


def cmd(
    module: str,
    action: str | None,
    guard: str,
    *updates: FlatUpdate,
    sp: SourceSpan | None = None,
    env: dict[str, Any] | None = None,
) -> FlatCommand:
    return FlatCommand(module, action, ex(guard, **(env or {})), tuple(updates), sp or A.NO_SPAN)


def module(
    name: str, variables: list[str], commands: list[FlatCommand], sp: SourceSpan | None = None
) -> FlatModule:
    return FlatModule(
        name,
        tuple(variables),
        tuple(commands),
        frozenset(c.action for c in commands if c.action is not None),
        sp or A.NO_SPAN,
    )


def flat_model(
    model_type: A.ModelType,
    variables: list[Variable],
    modules: list[FlatModule],
    *,
    players: list[FlatPlayer] | None = None,
    observables: list[FlatObservable] | None = None,
    labels: dict[str, Any] | None = None,
    rewards: list[FlatRewardStruct] | None = None,
    init: A.Expr | None = None,
) -> FlatModel:
    return FlatModel(
        model_type=model_type,
        variables=tuple(variables),
        modules=tuple(modules),
        players=tuple(players or ()),
        observables=None if observables is None else tuple(observables),
        labels=tuple(
            (k, ex(v) if isinstance(v, str) else lit(v)) for k, v in (labels or {}).items()
        ),
        rewards=tuple(rewards or ()),
        init=init,
        constants=(),
        file="test.prism",
    )


def obs(name: str, expr: str, sp: SourceSpan | None = None) -> FlatObservable:
    return FlatObservable(name, ex(expr), sp or A.NO_SPAN)


def player(
    name: str,
    modules: list[str] = (),
    actions: list[str] = (),
    observables: list[FlatObservable] | None = None,
) -> FlatPlayer:  # type: ignore[assignment]
    return FlatPlayer(
        name, tuple(modules), tuple(actions), None if observables is None else tuple(observables)
    )


def rewards(name: str | None, *items: tuple[Any, ...]) -> FlatRewardStruct:
    """Items: ``(guard, value)`` state rewards, ``(action or "", guard, value)`` action rewards."""
    out = []
    for it in items:
        if len(it) == 2:
            out.append(
                FlatRewardItem(
                    False, None, ex(it[0]) if isinstance(it[0], str) else lit(it[0]), lit(it[1])
                )
            )
        else:
            a = it[0] or None
            out.append(
                FlatRewardItem(
                    True, a, ex(it[1]) if isinstance(it[1], str) else lit(it[1]), lit(it[2])
                )
            )
    return FlatRewardStruct(name, tuple(out))


# ---------------------------------------------------------------------------------------------
# the scale models of tests/data/benchmarks/scale, hand-translated
# ---------------------------------------------------------------------------------------------


def two_robots(n: int) -> FlatModel:
    """``scale/two_robots.nm`` with N = n (s = 0.1, f = 0.002)."""
    s, f = Fraction(1, 10), Fraction(2, 1000)
    env: dict[str, Any] = {"N": n, "s": s, "f": f}
    env["collide"] = "x1==x2 and y1==y2"
    env["done"] = ex("(x1==N-1 and y1==N-1 and x2==0 and y2==0) or collide or dead", **env)
    mods = []
    for r in (1, 2):
        x, y = f"x{r}", f"y{r}"
        cmds = []
        for act, g, (v, e) in (
            (f"r{r}", f"{x}<N-1", (x, f"{x}+1")),
            (f"l{r}", f"{x}>0", (x, f"{x}-1")),
            (f"u{r}", f"{y}<N-1", (y, f"{y}+1")),
            (f"d{r}", f"{y}>0", (y, f"{y}-1")),
        ):
            cmds.append(
                cmd(
                    f"robot{r}",
                    act,
                    f"not done and {g}",
                    upd("1-s-f", (v, e), env=env),
                    upd("s", env=env),
                    upd("f", ("dead", True), env=env),
                    env=env,
                )
            )
        mods.append(module(f"robot{r}", [x, y], cmds))
    variables = [
        boolvar("dead"),
        var("x1", 0, n - 1, module="robot1"),
        var("y1", 0, n - 1, module="robot1"),
        var("x2", 0, n - 1, module="robot2"),
        var("y2", 0, n - 1, module="robot2"),
    ]
    moves = rewards(
        "moves", *[(a, True, 1) for a in ("r1", "l1", "u1", "d1", "r2", "l2", "u2", "d2")]
    )
    return flat_model(
        A.ModelType.MDP,
        variables,
        mods,
        init=ex("x1==0 and y1==0 and x2==N-1 and y2==N-1 and not dead", **env),
        labels={
            "goal": ex(
                "x1==N-1 and y1==N-1 and x2==0 and y2==0 and not collide and not dead", **env
            ),
            "crash": ex("collide", **env),
        },
        rewards=[moves],
    )


def pursuit(n: int) -> FlatModel:
    """``scale/pursuit.smg`` with N = n (s = 0.1, q = 0.7)."""
    env: dict[str, Any] = {"N": n, "s": Fraction(1, 10), "q": Fraction(7, 10)}
    env["caught"] = "ex==px and ey==py"
    env["escaped"] = ex("ex==N-1 and ey==N-1 and not caught", **env)
    env["over"] = ex("caught or escaped", **env)
    e_cmds = [
        cmd(
            "evader",
            a,
            f"turn==0 and not over and {g}",
            upd("1-s", (v, e), ("turn", 1), env=env),
            upd("s", ("turn", 1), env=env),
            env=env,
        )
        for a, g, v, e in (
            ("er", "ex<N-1", "ex", "ex+1"),
            ("el", "ex>0", "ex", "ex-1"),
            ("eu", "ey<N-1", "ey", "ey+1"),
            ("ed", "ey>0", "ey", "ey-1"),
        )
    ]
    p_cmds = [
        cmd(
            "pursuer",
            a,
            f"turn==1 and not over and {g}",
            upd("q", (v, e), ("turn", 0), env=env),
            upd("1-q", ("turn", 0), env=env),
            env=env,
        )
        for a, g, v, e in (
            ("pr", "px<N-1", "px", "px+1"),
            ("pl", "px>0", "px", "px-1"),
            ("pu", "py<N-1", "py", "py+1"),
            ("pd", "py>0", "py", "py-1"),
        )
    ]
    p_cmds.append(cmd("pursuer", "pw", "turn==1 and not over", upd(1, ("turn", 0)), env=env))
    variables = [
        var("turn", 0, 1),
        var("ex", 0, n - 1, module="evader"),
        var("ey", 0, n - 1, module="evader"),
        var("px", 0, n - 1, n - 1, module="pursuer"),
        var("py", 0, n - 1, module="pursuer"),
    ]
    return flat_model(
        A.ModelType.SMG,
        variables,
        [module("evader", ["ex", "ey"], e_cmds), module("pursuer", ["px", "py"], p_cmds)],
        players=[
            player("evader", actions=["er", "el", "eu", "ed"]),
            player("pursuer", actions=["pr", "pl", "pu", "pd", "pw"]),
        ],
        labels={"escaped": env["escaped"], "caught": ex("caught", **env)},
    )
