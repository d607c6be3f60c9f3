"""Front end, first stage: grammar loading, parsing, and the immutable syntax trees (no meaning
yet).

The parsing functions are re-exported here but loaded lazily, so that importing
``posgmc.syntax.ast`` (as every later stage does) does not build or even import the parser.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from posgmc.syntax.parser import (
        load_model,
        load_properties,
        parse_expression,
        parse_model,
        parse_properties,
        parse_property,
    )
    from posgmc.syntax.printer import format_expr

__all__ = [
    "parse_model",
    "parse_properties",
    "parse_property",
    "parse_expression",
    "load_model",
    "load_properties",
    "format_expr",
]

_LAZY = {
    "parse_model": "posgmc.syntax.parser",
    "parse_properties": "posgmc.syntax.parser",
    "parse_property": "posgmc.syntax.parser",
    "parse_expression": "posgmc.syntax.parser",
    "load_model": "posgmc.syntax.parser",
    "load_properties": "posgmc.syntax.parser",
    "format_expr": "posgmc.syntax.printer",
}


def __getattr__(name: str) -> Any:
    module_name = _LAZY.get(name)
    if module_name is None:
        raise AttributeError(f"module 'posgmc.syntax' has no attribute {name!r}")
    import importlib

    return getattr(importlib.import_module(module_name), name)
