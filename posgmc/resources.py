"""How much memory this process may still take, measured, and the check before a large allocation.

posgmc stops with a :class:`~posgmc.errors.LimitError` that says what it was building, how far it
got and how to go on, *before* an allocation the machine cannot satisfy, rather than dying in
``MemoryError`` or being killed by the kernel's OOM killer. What may still be taken is measured,
never a constant: the smaller of

* the memory the kernel reports available (``MemAvailable`` in ``/proc/meminfo``; the physical
  memory from ``sysconf`` where there is no ``/proc``), and
* the room left under the address-space limit (``RLIMIT_AS``, as set by ``ulimit -v``) above this
  process's current virtual size (``/proc/self/statm``).

Where neither can be measured, nothing is refused.
"""

from __future__ import annotations

import os
import resource

from posgmc.errors import LimitError

__all__ = ["available_bytes", "resident_bytes", "check_allocation", "format_bytes", "usable_cpus"]

_SAFETY = 0.9
"""The share of what is available that one allocation may take: the rest is headroom for the
interpreter, the temporaries of numpy operations and the other arrays alive at the time."""


def _meminfo_available() -> int | None:
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (OSError, ValueError, AttributeError):
        return None


def _statm(field: int) -> int | None:
    try:
        with open("/proc/self/statm", encoding="ascii") as f:
            return int(f.read().split()[field]) * int(os.sysconf("SC_PAGE_SIZE"))
    except (OSError, ValueError, IndexError):
        return None


def resident_bytes() -> int | None:
    """The resident memory of this process now (None where it cannot be measured)."""
    return _statm(1)


def _address_space_room() -> int | None:
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft == resource.RLIM_INFINITY or soft < 0:
        return None
    virtual = _statm(0) or 0
    return max(0, soft - virtual)


def available_bytes() -> int | None:
    """What this process may still allocate: the smaller of the kernel's available memory and the
    room under ``RLIMIT_AS`` (None when neither can be measured)."""
    known = [b for b in (_meminfo_available(), _address_space_room()) if b is not None]
    return min(known) if known else None


def format_bytes(n: float) -> str:
    """``n`` bytes for people: ``512 B``, ``3.2 MB``, ``1.4 GB`` (powers of 1000)."""
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if abs(n) < 1000 or unit == "PB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000
    return f"{n:.1f} PB"  # pragma: no cover - the loop returns


def check_allocation(num_bytes: float, what: str, *, hint: str | None = None) -> None:
    """Refuse an allocation of ``num_bytes`` that would not fit in what is available.

    Args:
        num_bytes: the size of what is about to be allocated (may be a float: sizes are products
            of counts and can exceed 64 bits).
        what: what is being built, for the message ("the product of 12 states with memory 10^6").
        hint: how to go on (a smaller input, an option to raise or lower).

    Raises:
        LimitError: ``num_bytes`` is more than the measured available memory allows; the message
            gives both sizes.
    """
    available = available_bytes()
    if available is None or num_bytes <= _SAFETY * available:
        return
    raise LimitError(
        f"{what} would need {format_bytes(num_bytes)}, but only {format_bytes(available)} of "
        "memory is available",
        hint=hint,
    )


def usable_cpus() -> int:
    """The processors this process may run on (its CPU affinity; the machine's count where that
    cannot be read): more worker processes than this only compete for them."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)
