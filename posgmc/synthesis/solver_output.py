"""Keeping a solver library's own prints off the process's standard output.

scipy's HiGHS prints a debug line from C (``HighsMipSolverData::transformNewIntegerFeasibleSolution
tmpSolver.run();``) straight to file descriptor 1 whatever its options say, which would land in the
middle of ``--json`` output. :func:`c_stdout_silenced` points descriptor 1 at the null device for
the duration of a call, flushing Python's and C's buffers on both sides so that nothing written
before is lost and nothing the library buffered escapes afterwards. Only the calling thread's
solver runs meanwhile (posgmc writes its own output from the main thread, between solver calls).
"""

from __future__ import annotations

import ctypes
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["c_stdout_silenced"]


def _flush_c_stdio() -> None:
    """fflush(NULL): every C stdio stream's buffer out to its descriptor (a no-op where the C
    library cannot be reached)."""
    try:
        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError, TypeError):
        pass


@contextmanager
def c_stdout_silenced() -> Iterator[None]:
    """Descriptor 1 goes to the null device inside the block (when it is open at all)."""
    try:
        sys.stdout.flush()
    except (OSError, ValueError):
        pass
    _flush_c_stdio()
    try:
        saved = os.dup(1)
    except OSError:  # no standard output to protect
        yield
        return
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        yield
    finally:
        _flush_c_stdio()
        os.dup2(saved, 1)
        os.close(saved)
        os.close(null)
