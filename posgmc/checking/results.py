"""What checking a property answers: a value with the bounds that hold, and where it came from."""

from __future__ import annotations

import builtins
import enum
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np


class ResultKind(enum.Enum):
    PROBABILITY = "probability"
    REWARD = "reward"
    BOOLEAN = "boolean"
    NUMBER = "number"  # arithmetic over queries


@dataclass(frozen=True, eq=False)
class PropertyResult:
    """The answer to one property at the model's initial state(s).

    ``value`` is the reported number (or bool for threshold properties); ``lower``/``upper`` are
    proven bounds on the exact value (equal to ``value`` for exact methods, None for booleans).
    A Boolean is ``True``/``False`` only when proven (``sound``) or decided by an unsound method
    (``sound`` False); ``None`` means **unknown**: the proven bounds still straddle a threshold
    after refinement (see :meth:`posgmc.checking.dispatch.PropertyChecker.check`).
    With several initial states, a numeric value is the one of the first initial state and
    ``per_initial`` lists them all; a boolean holds when it holds in every initial state (PRISM).
    ``note`` says what the number means when it is not the plain answer (e.g. a full-observation
    bound on a partially observable model).
    """

    property: str
    name: str | None
    kind: ResultKind
    value: float | bool | None
    lower: float | None
    upper: float | None
    seconds: float
    method: str
    iterations: int = 0
    converged: bool = True
    sound: bool = True
    note: str | None = None
    per_initial: tuple[float | bool | None, ...] = ()
    values: np.ndarray | None = field(default=None, repr=False)
    strategy: np.ndarray | None = field(default=None, repr=False)

    # the field "property" shadows the builtin inside this class body
    @builtins.property
    def is_unknown(self) -> bool:
        """A Boolean property left undecided by the proven bounds."""
        return self.kind is ResultKind.BOOLEAN and self.value is None

    @builtins.property
    def is_decided(self) -> bool:
        """A Boolean property decided on proven bounds (True for every non-Boolean result)."""
        return self.kind is not ResultKind.BOOLEAN or (self.value is not None and self.sound)

    def to_json(self) -> dict[str, Any]:
        """The documented machine-readable form (see docs/cli.md)."""

        def num(x: float | bool | None) -> Any:
            if x is None and self.kind is ResultKind.BOOLEAN:
                return "unknown"
            if x is None or isinstance(x, bool):
                return x
            if math.isinf(x):
                return "inf" if x > 0 else "-inf"
            if math.isnan(x):
                return None
            return float(x)

        out: dict[str, Any] = {
            "property": self.property,
            "name": self.name,
            "kind": self.kind.value,
            "value": num(self.value),
            "lower": None if self.lower is None else num(self.lower),
            "upper": None if self.upper is None else num(self.upper),
            "seconds": round(self.seconds, 6),
            "method": self.method,
            "iterations": self.iterations,
            "converged": self.converged,
            "sound": self.sound,
        }
        if self.note:
            out["note"] = self.note
        if len(self.per_initial) > 1:
            out["per_initial"] = [num(v) for v in self.per_initial]
        return out
