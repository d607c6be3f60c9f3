"""posgmc.processes: the processes below this one are found, grandchildren included, and ended —
by SIGTERM, or by SIGKILL after the grace for one that ignores it; a process that is gone, or
whose pid now names another process, is left alone."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import pytest

from posgmc.processes import descendants, end

pytestmark = pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="reads Linux's /proc")

# a child that starts a grandchild ignoring SIGTERM, prints its pid, and sleeps
PARENT = """
import signal, subprocess, sys, time
child = subprocess.Popen([sys.executable, "-c",
    "import signal, time; signal.signal(signal.SIGTERM, signal.SIG_IGN); time.sleep(60)"])
print(child.pid, flush=True)
time.sleep(60)
"""


def test_children_and_grandchildren_are_found_and_ended() -> None:
    parent = subprocess.Popen([sys.executable, "-c", PARENT], stdout=subprocess.PIPE, text=True)
    try:
        assert parent.stdout is not None
        grandchild = int(parent.stdout.readline())
        below = descendants()
        pids = {pid for pid, _ in below}
        assert {parent.pid, grandchild} <= pids
        t0 = time.monotonic()
        end({p for p in below if p[0] in (parent.pid, grandchild)}, grace=0.5)
        assert time.monotonic() - t0 < 10
        parent.wait(timeout=10)
        # the grandchild is gone, or a zombie waiting for its new parent to reap it: not running
        assert _state(grandchild) in ("", "Z", "X")
    finally:
        if parent.poll() is None:
            parent.kill()
            parent.wait()


def test_a_process_no_longer_there_is_left_alone() -> None:
    done = subprocess.Popen([sys.executable, "-c", "pass"])
    found = {p for p in descendants() if p[0] == done.pid}
    done.wait()
    end(found | {(done.pid, 0)}, grace=0.1)  # gone, and a start time that is not its: no error


def _state(pid: int) -> str:
    """The process's state letter ("" when it is gone)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            text = f.read()
    except OSError:
        return ""
    return text[text.rfind(")") + 2]
