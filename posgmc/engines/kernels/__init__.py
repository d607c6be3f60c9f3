"""Compiled kernels for the engines' hot loops, with the numpy/scipy paths as the fallback.

A kernel is written once as a plain Python function over numpy arrays and scalars (no objects,
no Python containers) and wrapped by :func:`compiled`: with numba installed it is compiled to
machine code on first call (cached on disk beside its module, so a later process only loads
it); without numba, or with the environment variable ``POSGMC_KERNELS=numpy``, :func:`enabled`
is False and the caller takes its vectorised numpy/scipy path instead. A kernel's Python body is
never run uncompiled on a hot path: a loop per state in the interpreter is what kernels replace.

numba itself is imported on the first kernel call, not when posgmc is imported: its start-up (the
import, then its first-call initialisation, about as long again) costs a fraction of a second of
CPU and on the order of 100 MB per process, which a check that needs no kernel should not pay, and
which is why small systems keep the numpy paths (:data:`posgmc.engines.scc.COMPILED_MIN_SIZE`).
A process that is about to need the kernels (``api.build``: a check follows) calls
:func:`warm_up_in_background`: numba's import, its first-call initialisation and the loading of
the cached machine code of the registered kernels (:func:`on_warm_up`) then run on a daemon
thread while the model is built, instead of inside the first check.

Call sites ask :func:`enabled` at call time (not at import), so the tests can run both paths in
one process by flipping :data:`STATE`. Why numba and not a C extension: ``docs/architecture.md``
("Compiled kernels").
"""

from __future__ import annotations

import importlib.util
import os
import threading
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
            with _COMPILE_LOCK:  # the warm-up thread may be creating it right now
                if self._compiled is None:
                    import numba

                    self._compiled = numba.njit(cache=True, nogil=True)(self.py_func)
        return self._compiled(*args)


_COMPILE_LOCK = threading.RLock()


def compiled(fn: F) -> Kernel[F]:
    """``fn`` as a :class:`Kernel`; call it only when :func:`enabled` is True."""
    return Kernel(fn)


@dataclass
class _WarmUp:
    """The registered warm-up calls and the thread running them (mutable: process state)."""

    calls: list[Callable[[], object]]
    thread: threading.Thread | None = None


_WARM_UP = _WarmUp(calls=[])


def on_warm_up(call: Callable[[], object]) -> None:
    """Register ``call`` (no arguments) to run on the warm-up thread: it should call its module's
    kernels once on tiny arrays of the dtypes the hot paths pass, so that their cached machine
    code is loaded (a kernel call with other dtypes loads or compiles another variant)."""
    _WARM_UP.calls.append(call)


def warm_up_in_background() -> None:
    """Start the warm-up thread (once per process; nothing when the kernels are off)."""
    if not enabled() or _WARM_UP.thread is not None:
        return
    thread = threading.Thread(target=_run_warm_up, name="posgmc-kernel-warm-up", daemon=True)
    _WARM_UP.thread = thread
    thread.start()


def _run_warm_up() -> None:
    for call in _WARM_UP.calls:
        try:
            call()
        except Exception:  # noqa: BLE001 - the same call fails again, visibly, in the foreground
            return


def _join_warm_up() -> None:
    """Let a running warm-up finish before the process forks (a child must not inherit its
    locks half-held)."""
    thread = _WARM_UP.thread
    if thread is not None and thread.is_alive():
        thread.join()


os.register_at_fork(before=_join_warm_up)
