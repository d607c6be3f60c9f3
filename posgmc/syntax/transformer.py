"""Build the immutable syntax tree (``ast.py``) while parsing, with a span on every node.

The grammar (``grammar/prism.lark``) decides the shape; this module holds the semantic action of
each grammar rule (:class:`AstBuilder`, bound to the rules by :func:`rule_actions`), which
``parser.py`` runs during the LALR parse, so that no parse tree is built and walked. Besides
converting, it does the few checks that are syntax in PRISM but easier to do on the tree: label
and observable names must be identifiers, function names and arities, one model type and one
``init`` block per file, player items separated by commas, temporal operators only inside
``P[..]``/``R[..]``, and the classification of reward objectives (``F phi`` with a state formula
``phi`` is a reachability reward; any other path formula is a co-safe LTL objective).

The actions live in :mod:`~posgmc.syntax.actions_model` (model files) and
:mod:`~posgmc.syntax.actions_expr` (expressions and properties) over
:mod:`~posgmc.syntax.actions_base`; the records they pass upwards are in
:mod:`~posgmc.syntax.items`, the temporal-placement check in :mod:`~posgmc.syntax.placement`.
This module puts them together and binds them to the grammar's rules.
"""

from __future__ import annotations

import operator
from collections.abc import Callable, Sequence
from typing import Any

from lark import Token
from lark.grammar import Rule, Terminal

from posgmc.errors import SourceSpan
from posgmc.syntax.actions_expr import ExpressionActions
from posgmc.syntax.actions_model import ModelActions
from posgmc.syntax.ast import BinaryOp
from posgmc.syntax.items import PropertyItem
from posgmc.syntax.placement import binary, check_temporal_placement, contains_temporal

__all__ = [
    "AstBuilder",
    "PropertyItem",
    "RuleAction",
    "check_temporal_placement",
    "contains_temporal",
    "rule_actions",
]


class AstBuilder(ModelActions, ExpressionActions):
    """The semantic actions of the LALR parse: grammar rule -> ``ast.py`` node; one instance per
    parse (it knows the file name and collects the first conversion error).

    Each action gets the span of the rule's text and the rule's children as lark would put them in
    a tree node: named tokens and nonterminal values, anonymous tokens (``"("``, ``";"``) left
    out, and the items of ``_``-prefixed rules and repetitions spliced in. :func:`rule_actions`
    binds the actions to the grammar's rules; ``parser.py`` calls them while parsing.

    Errors found here (a label that is not an identifier, a wrong arity, ...) do not stop the
    parse: the first one is kept in :attr:`error` and the action returns a stand-in, so that a
    syntax error further on is reported first, as when the conversion ran on a finished tree.
    """

    # actions that never use their span: it is not computed for them
    SPANLESS = frozenset(
        {
            "properties_file", "single_property", "single_expression", "single_model_expression",
            "const_type", "global_decl", "range_type", "bool_type", "int_type", "updates",
            "all_players", "player_list", "relop", "reward_index", "op_value", "op_min", "op_max",
        }
    )  # fmt: skip


# --- binding the actions to the grammar's rules ---------------------------------------------------

# (builder, the rule's values as on the parse stack, the first token of its text, the last)
RuleAction = Callable[[AstBuilder, list[Any], Token | None, Token | None], Any]

_BINARY_OPS: dict[str, BinaryOp] = {
    "implies": BinaryOp.IMPLIES,
    "iff": BinaryOp.IFF,
    "or_": BinaryOp.OR,
    "and_": BinaryOp.AND,
    "eq": BinaryOp.EQ,
    "ne": BinaryOp.NE,
    "lt": BinaryOp.LT,
    "le": BinaryOp.LE,
    "gt": BinaryOp.GT,
    "ge": BinaryOp.GE,
    "add": BinaryOp.ADD,
    "sub": BinaryOp.SUB,
    "mul": BinaryOp.MUL,
    "div": BinaryOp.DIV,
}


def rule_actions(rules: Sequence[Rule]) -> list[RuleAction | None]:
    """The semantic action of each grammar rule, in the order of ``rules``.

    Mirrors what lark's tree builder does with ``propagate_positions=True`` followed by a
    ``Transformer``, so that values and spans are the same: anonymous tokens are dropped
    (unless the rule is ``!``-prefixed), the items of ``_``-prefixed rules are spliced into
    their parent, a ``?``-rule with one remaining child is that child, and a node's span runs
    from the start of its first symbol's text to the end of its last one's (parentheses
    included: the span of ``(a) + b`` starts at ``(``, that of ``a`` inside stays ``a``).

    Args:
        rules: lark's compiled rules (``Lark.rules``; the parse table refers to the same objects).

    Returns:
        For each rule ``None`` when the rule has one symbol and passes its value through unchanged
        (the parser then only changes state), else a callable ``(builder, values, first_token,
        last_token) -> value``; for a rule without symbols the two tokens are ``None``.

    Raises:
        TypeError: a rule this module has no action for (the grammar and this module disagree).
    """
    return [_rule_action(rule) for rule in rules]


def _rule_action(rule: Rule) -> RuleAction | None:
    name = rule.alias or rule.options.template_source or rule.origin.name
    keep_all = rule.options.keep_all_tokens
    size = len(rule.expansion)
    # (position in the expansion, whether its value is a list to splice in)
    kept = [
        (i, not sym.is_term and sym.name.startswith("_"))
        for i, sym in enumerate(rule.expansion)
        if keep_all or not (isinstance(sym, Terminal) and sym.filter_out)
    ]
    if rule.options.expand1 and not rule.alias:
        if len(kept) != 1 or kept[0][1]:
            raise TypeError(f"grammar rule {rule} would be inlined only sometimes")
        if size == 1:
            return None
        index = kept[0][0]
        return lambda b, c, s, e: c[index]  # the child, with the extent of the whole rule
    if rule.origin.name.startswith("_") and not rule.alias:
        # the value of a rule whose items are spliced into its parent: a list of them
        splice = _selector(kept, size, as_list=True)
        if splice is None:
            return lambda b, c, s, e: c
        return lambda b, c, s, e: splice(c)
    select = _selector(kept, size, as_list=False)
    if name in _BINARY_OPS:
        op = _BINARY_OPS[name]
        if [i for i, _ in kept] != [0, 2] or size != 3:
            raise TypeError(f"grammar rule {rule} is not a binary operator")
        return lambda b, c, s, e: binary(op, c[0], c[2], _extent(b, s, e))
    method = getattr(AstBuilder, name, None)
    if method is None or name.startswith("_"):
        raise TypeError(f"no action for grammar rule {rule}")
    if size == 0:
        return lambda b, c, s, e: method(b, SourceSpan(0, 0, file=b.file), [])
    spanless = name in AstBuilder.SPANLESS
    if select is None:
        if spanless:
            return lambda b, c, s, e: method(b, None, c)
        return lambda b, c, s, e: method(b, _extent(b, s, e), c)
    if spanless:
        return lambda b, c, s, e: method(b, None, select(c))
    return lambda b, c, s, e: method(b, _extent(b, s, e), select(c))


def _extent(b: AstBuilder, s: Token | None, e: Token | None) -> SourceSpan:
    """The span from the first token ``s`` to the last ``e`` of a reduction (no position when
    the rule's text begins or ends with an empty rule, which has no tokens; lark's tokens may lack
    a position, the lexer's never do)."""
    if s is None or e is None or s.line is None or s.column is None:
        return SourceSpan(0, 0, file=b.file)
    return SourceSpan(s.line, s.column, e.end_line, e.end_column, b.file)


def _selector(
    kept: list[tuple[int, bool]], size: int, *, as_list: bool
) -> Callable[[list[Any]], Sequence[Any]] | None:
    """The function picking a rule's children out of its stack values (``None``: all of them, as
    the list they come in); ``as_list`` asks for a list (to be spliced, or extended in place)."""
    splice = any(expand for _, expand in kept)
    positions = [i for i, _ in kept]
    if not splice:
        if positions == list(range(size)):
            return None
        if as_list:
            return lambda c: [c[i] for i in positions]
        if not positions:
            return lambda c: ()
        if len(positions) == 1:
            only = positions[0]
            return lambda c: (c[only],)
        return operator.itemgetter(*positions)

    def select(c: list[Any]) -> list[Any]:
        out: list[Any] = []
        for i, expand in kept:
            if not expand:
                out.append(c[i])
            elif out:
                out += c[i]
            else:
                # the list of a left-recursive repetition is extended in place, not copied
                # (it is consumed by this reduction), as lark's tree builder does
                out = c[i]
        return out

    return select
