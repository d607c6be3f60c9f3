"""``--const`` as the commands read it: PRISM's ``N=4,p=0.9`` with sweeps ``N=1:1:5``, expanded into
one setting per combination, or refused where a command takes single values."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import TYPE_CHECKING, Any

from posgmc.errors import InputError

if TYPE_CHECKING:
    from posgmc.semantics.constants import ConstRange, ConstSetting, UserConstant

__all__ = ["const_assignments", "expand_constants", "const_json", "const_text",
           "single_constants"]


def const_assignments(values: Sequence[str]) -> Iterator[tuple[str, ConstSetting | ConstRange]]:
    """Each ``name=value`` (or range) of the ``--const`` options in order, with its position in
    its option's text (the source is named ``--const``, or ``--const #i`` among several).

    Raises:
        ConstantError: malformed text, with its position.
    """
    from posgmc.semantics.constants import parse_const_assignments

    for i, text in enumerate(values):
        source = "--const" if len(values) == 1 else f"--const #{i + 1}"
        yield from parse_const_assignments(text, source=source).items()


def expand_constants(
    values: Sequence[str],
) -> tuple[list[str], list[dict[str, ConstSetting | UserConstant]]]:
    """``("N=4,p=0.9", "k=0:5")`` -> (swept names, one name->setting dict per combination).

    Raises:
        ConstantError: malformed text, a name given twice (with the position in the option's text).
    """
    from posgmc.errors import ConstantError
    from posgmc.semantics.constants import ConstRange, expand_sweep

    merged: dict[str, ConstSetting | ConstRange] = {}
    for name, setting in const_assignments(values):
        if name in merged:
            raise ConstantError(f"constant '{name}' is given twice", setting.span)
        merged[name] = setting
    swept = [n for n, v in merged.items() if isinstance(v, ConstRange)]
    return swept, expand_sweep(merged) if merged else []


def const_text(setting: Any) -> str:
    from posgmc.semantics.evaluate import format_value

    value = getattr(setting, "value", setting)
    return value if isinstance(value, str) else format_value(value)


def const_json(setting: Any) -> Any:
    """A constant's value in JSON: a number or a Boolean as JSON has them (``"start": 3``, not
    ``"3"``), text only for what is neither (e.g. a fraction ``1/3``)."""
    import math

    value = getattr(setting, "value", setting)
    if not isinstance(value, str):
        return value if isinstance(value, (bool, int, float)) else const_text(value)
    text = value.strip()
    if text in ("true", "false"):
        return text == "true"
    for parse in (int, float):
        try:
            number = parse(text)
        except ValueError:
            continue
        if isinstance(number, int) or math.isfinite(number):
            return number
    return text


def single_constants(consts: Sequence[str], *, what: str) -> dict[str, Any]:
    """``--const`` settings of a command that takes single values (``what`` names the command or
    its object in the error).

    Raises:
        InputError: a range, at its position in the option's text; ConstantError as
            :func:`expand_constants`.
    """
    from posgmc.semantics.constants import ConstRange

    for n, setting in const_assignments(consts):
        if isinstance(setting, ConstRange):
            raise InputError(f"--const {n}: {what} takes single values, not ranges", setting.span)
    _, combos = expand_constants(consts)
    return dict(combos[0]) if combos else {}
