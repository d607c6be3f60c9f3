"""The processes this process started, directly or through its children, and ending those that
outlive their purpose: a Ray started on this machine for one run leaves helper processes (its
dashboard and runtime-environment agents) behind when its raylet ends, which nothing else ends.

Read from Linux's ``/proc``; elsewhere nothing is found and nothing is ended. A process is named by
its pid and its start time (``/proc/PID/stat`` field 22), so a pid the system has since given to
another process is never signalled.
"""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

__all__ = ["Process", "descendants", "end"]

Process = tuple[int, int]
"""A process: its pid and its start time (clock ticks after boot)."""

_PROC = Path("/proc")


def _stat(pid: int) -> tuple[int, int] | None:
    """(parent pid, start time) of ``pid``; None when it is gone or unreadable."""
    try:
        text = (_PROC / str(pid) / "stat").read_text()
    except OSError:
        return None
    # the command name (field 2) is in parentheses and may hold spaces: fields after its end
    fields = text[text.rfind(")") + 2:].split()
    try:
        return int(fields[1]), int(fields[19])
    except (IndexError, ValueError):
        return None


def descendants(pid: int | None = None) -> set[Process]:
    """Every process below ``pid`` (default: this one) in the process tree, as it is now."""
    root = os.getpid() if pid is None else pid
    children: dict[int, list[Process]] = {}
    try:
        entries = [int(e.name) for e in _PROC.iterdir() if e.name.isdigit()]
    except OSError:
        return set()
    for entry in entries:
        stat = _stat(entry)
        if stat is not None:
            children.setdefault(stat[0], []).append((entry, stat[1]))
    out: set[Process] = set()
    stack = [root]
    while stack:
        for child in children.get(stack.pop(), []):
            if child not in out:
                out.add(child)
                stack.append(child[0])
    return out


def _alive(process: Process) -> bool:
    stat = _stat(process[0])
    return stat is not None and stat[1] == process[1] and not _zombie(process[0])


def _zombie(pid: int) -> bool:
    try:
        text = (_PROC / str(pid) / "stat").read_text()
    except OSError:
        return True
    return text[text.rfind(")") + 2:].startswith(("Z", "X"))


def _signal(process: Process, signum: int) -> None:
    if _alive(process):
        try:
            os.kill(process[0], signum)
        except OSError:  # gone meanwhile, or not ours to signal
            pass


def end(processes: set[Process], *, grace: float = 2.0) -> None:
    """End those of ``processes`` that still run: SIGTERM, and SIGKILL after ``grace`` seconds
    for any that ignores it."""
    for process in processes:
        _signal(process, signal.SIGTERM)
    stop = time.monotonic() + grace
    while any(_alive(p) for p in processes) and time.monotonic() < stop:
        time.sleep(0.05)
    for process in processes:
        _signal(process, signal.SIGKILL)
