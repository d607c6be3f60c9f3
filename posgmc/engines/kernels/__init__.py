"""Compiled kernels for the engines' hot loops, with the numpy/scipy paths as the fallback.

A kernel is written once as a plain Python function over numpy arrays and scalars (no objects,
no Python containers) and wrapped by :func:`compiled`: with numba installed it is compiled to
machine code on first call (cached on disk beside its module, so a later process only loads
it); without numba, or with the environment variable ``POSGMC_KERNELS=numpy``, :func:`enabled`
is False and the caller takes its vectorised numpy/scipy path instead. A kernel's Python body is
never run uncompiled on a hot path: a loop per state in the interpreter is what kernels replace.

numba itself is imported on the first kernel call, not when posgmc is imported (the import costs
about 0.4 s, which a check that needs no kernel should not pay).

Call sites ask :func:`enabled` at call time (not at import), so the tests can run both paths in
one process by flipping :data:`STATE`. Why numba and not a C extension: ``docs/architecture.md``
("Compiled kernels").
"""

from __future__ import annotations

import importlib.util
import os
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

F = TypeVar("F", bound=Callable[..., Any])


@dataclass
class KernelState:
    """Whether the compiled kernels are used (mutable on purpose: the tests switch it)."""

    use: bool


_AVAILABLE = importlib.util.find_spec("numba") is not None

STATE = KernelState(use=_AVAILABLE and os.environ.get("POSGMC_KERNELS", "") != "numpy")


def available() -> bool:
    """numba is installed (whatever :data:`STATE` says)."""
    return _AVAILABLE


def enabled() -> bool:
    """The compiled kernels are to be used now."""
    return STATE.use and _AVAILABLE


class Kernel(Generic[F]):
    """A function compiled by numba on its first call (``nopython``, ``nogil``, disk-cached)."""

    def __init__(self, fn: F) -> None:
        self.py_func = fn
        self._compiled: Any = None

    def __call__(self, *args: Any) -> Any:
        if self._compiled is None:
            import numba

            self._compiled = numba.njit(cache=True, nogil=True)(self.py_func)
        return self._compiled(*args)


def compiled(fn: F) -> Kernel[F]:
    """``fn`` as a :class:`Kernel`; call it only when :func:`enabled` is True."""
    return Kernel(fn)
