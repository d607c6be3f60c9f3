"""posgmc: model checking and strategy synthesis for partially observable stochastic games.

The stages at top level, as stormpy's and lark's users expect (loaded on first use, so that
``import posgmc`` stays cheap)::

    import posgmc

    session = posgmc.load("models/rover.smg")
    report = posgmc.check(session, properties=['<<rover>> Pmax=? [ !"crash" U "goal" ]'])
    result = report.results[0]          # a PropertyResult: value, lower, upper, ...

    defence = posgmc.synthesize(posgmc.load("models/beacon/beacon.posg"),
                                '<<rover>> Pmax=? [ F "safe" ]', memory=2)

:mod:`posgmc.api` has the same functions with their full documentation.
"""

from __future__ import annotations

from importlib import import_module
from importlib.metadata import PackageNotFoundError, version
from typing import Any

try:
    __version__ = version("posgmc")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0.0.0+unknown"

_WHERE = {
    # stages
    "load": "posgmc.api",
    "parse_properties": "posgmc.api",
    "lint": "posgmc.api",
    "build": "posgmc.api",
    "check": "posgmc.api",
    "iter_check": "posgmc.api",
    "synthesize": "posgmc.api",
    "simulate": "posgmc.api",
    "load_strategy": "posgmc.api",
    "save_strategy": "posgmc.api",
    "read_drn": "posgmc.io.drn",
    "write_drn": "posgmc.io.drn",
    # records and options
    "Session": "posgmc.api",
    "BuiltModel": "posgmc.api",
    "CheckReport": "posgmc.api",
    "PropertyError": "posgmc.api",
    "PropertyResult": "posgmc.checking.results",
    "Bound": "posgmc.checking.results",
    "ExplicitModel": "posgmc.model.explicit",
    "FiniteStateStrategy": "posgmc.strategies.fss",
    "BuildOptions": "posgmc.compiler",
    "CheckOptions": "posgmc.checking.property_checker",
    "SolverOptions": "posgmc.engines.options",
    "Method": "posgmc.engines.options",
    "SynthesisOptions": "posgmc.synthesis.search",
    # errors
    "PosgmcError": "posgmc.errors",
    "InputError": "posgmc.errors",
    "ParseError": "posgmc.errors",
    "SemanticError": "posgmc.errors",
    "ConstantError": "posgmc.errors",
    "BuildError": "posgmc.errors",
    "ModelFormatError": "posgmc.errors",
    "UnsupportedError": "posgmc.errors",
    "LimitError": "posgmc.errors",
    "MultipleErrors": "posgmc.errors",
}

__all__ = ["__version__", *_WHERE]


def __getattr__(name: str) -> Any:
    """The names of :data:`__all__`, imported from their module on first use (PEP 562)."""
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module 'posgmc' has no attribute {name!r}")
    value = getattr(import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
