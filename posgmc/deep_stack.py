"""Run posgmc's work on a thread with a deep stack, so generated models nest as deep as they like.

Machine-generated PRISM files nest expressions hundreds deep (a guard ``x=0|x=1|...|x=199`` is a
199-deep tree, 500 chained ``!``, 300 nested ``X`` in a property). The walks over those trees
(transformer, resolution, type checking, constant evaluation, property rewriting) recurse once
per level, and Python's default limit of 1000 frames on the main thread's 8 MiB stack stops them.
:func:`deep_call` runs a function on a worker thread whose stack is :data:`STACK_BYTES` with the
recursion limit raised to :data:`MAX_FRAMES`; the main thread waits, so Ctrl-C still arrives
there, and every exception (``KeyboardInterrupt`` included) is re-raised in the caller.

Nesting beyond that is refused with :class:`~posgmc.errors.LimitError` (exit 2), never a crash.
The expression compiler does not rely on this: it generates code iteratively and cuts deep
expressions into temporaries (:mod:`posgmc.compiler.compile_expr`).
"""

from __future__ import annotations

import functools
import sys
import threading
from collections.abc import Callable, Iterator
from typing import ParamSpec, TypeVar

from posgmc.errors import LimitError

__all__ = ["MAX_FRAMES", "STACK_BYTES", "deep_call", "deep_generator", "deep_stack"]

STACK_BYTES = 512 * 1024 * 1024
"""Stack of the worker thread: reserved address space, only the pages used are ever touched."""

MAX_FRAMES = 60_000
"""Python frames allowed on the worker: about 10,000 levels of expression nesting."""

T = TypeVar("T")
P = ParamSpec("P")
_local = threading.local()
_limit_lock = threading.Lock()
_active = 0  # workers running; the raised limit is restored when the last one ends
_saved_limit = 0


def _raise_limit() -> None:
    # the recursion limit is per process: raise it while any worker runs, so that one caller's
    # worker finishing never lowers it under another's
    global _active, _saved_limit
    with _limit_lock:
        if _active == 0:
            _saved_limit = sys.getrecursionlimit()
            sys.setrecursionlimit(max(_saved_limit, MAX_FRAMES))
        _active += 1


def _restore_limit() -> None:
    global _active
    with _limit_lock:
        _active -= 1
        if _active == 0:
            sys.setrecursionlimit(_saved_limit)


def deep_call(fn: Callable[[], T]) -> T:
    """``fn()`` on a deep-stack worker thread (directly when already on one).

    Raises:
        LimitError: the input nests deeper than even the worker's stack allows.
        whatever ``fn`` raises.
    """
    if getattr(_local, "deep", False):
        return fn()
    value: list[T] = []  # the worker's result, or
    error: list[BaseException] = []  # what it raised

    def work() -> None:
        _local.deep = True
        try:
            value.append(fn())
        except RecursionError:
            error.append(
                LimitError(
                    "the input nests too deeply to process "
                    f"(more than about {MAX_FRAMES // 6} levels)",
                    hint="split the expression with formulas or constants",
                )
            )
        except BaseException as e:  # noqa: BLE001 - re-raised in the caller's thread below
            error.append(e)
        finally:
            _restore_limit()  # by the worker itself: balanced even if the caller was interrupted

    _raise_limit()
    old_size = threading.stack_size()
    try:
        threading.stack_size(STACK_BYTES)
        worker = threading.Thread(target=work, name="posgmc-deep", daemon=True)
        worker.start()
    except BaseException:
        _restore_limit()
        raise
    finally:
        threading.stack_size(old_size)
    worker.join()  # Ctrl-C interrupts this wait in the main thread, as it should
    if error:
        raise error[0]
    return value[0]


def deep_stack(f: Callable[P, T]) -> Callable[P, T]:
    """Decorator: ``f`` always runs with :func:`deep_call`."""

    @functools.wraps(f)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> T:
        return deep_call(lambda: f(*args, **kwargs))

    return wrapper


def deep_generator(f: Callable[P, Iterator[T]]) -> Callable[P, Iterator[T]]:
    """Decorator for a generator: each step runs with :func:`deep_call`."""

    @functools.wraps(f)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> Iterator[T]:
        steps = f(*args, **kwargs)
        while True:
            try:
                item = deep_call(lambda: next(steps))
            except StopIteration:
                return
            yield item

    return wrapper
