"""Showing synthesis progress (:mod:`posgmc.synthesis.progress`) on the command line: a live status
line (``rich``) when stderr is a terminal, lines on stderr with ``--progress`` (at least one every
:data:`HEARTBEAT` seconds, and one at every change of phase), progress events on stdout with
``--json-lines``, nothing with ``--quiet``."""

from __future__ import annotations

import dataclasses
import json
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from enum import Enum
from typing import Any

import click

from posgmc.synthesis import progress
from posgmc.synthesis.budget import interrupted

__all__ = ["ProgressMode", "progress_mode", "progress_view", "before_output", "HEARTBEAT"]

HEARTBEAT = 2.0
"""Seconds between two ``--progress`` lines at most."""

_LIVE: list[Any] = []
"""The live display while one is shown (rich's ``Live``)."""

_HOLD = [False]
"""Whether the live line stays blank until the next progress event (a result was printed)."""


def before_output() -> None:
    """Blank the live status line before a result is printed on stdout: a stdout that is not a
    terminal (``| less``) may still end on the same screen, where the line would run into the
    result. The next progress event shows it again."""
    _HOLD[0] = True
    for live in _LIVE:
        live.refresh()


class ProgressMode(Enum):
    NONE = "none"
    LIVE = "live"
    LINES = "lines"
    JSON = "json"


def progress_mode(*, quiet: bool, lines: bool, json_lines: bool) -> ProgressMode:
    """What the options and stderr ask for: ``--quiet`` wins; ``--json-lines`` gives events on
    stdout; a terminal gets the live line; ``--progress`` lines elsewhere; a non-terminal
    without ``--progress``: nothing."""
    if quiet:
        return ProgressMode.NONE
    if json_lines:
        return ProgressMode.JSON
    if _is_terminal():
        return ProgressMode.LIVE
    return ProgressMode.LINES if lines else ProgressMode.NONE


def _is_terminal() -> bool:
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):
        return False


def _stdout_is_terminal() -> bool:
    try:
        return sys.stdout.isatty()
    except (AttributeError, ValueError):
        return False


def _now(status: progress.Status) -> progress.Status:
    """``status`` with its elapsed time brought up to now."""
    return dataclasses.replace(status, elapsed=status.elapsed + time.perf_counter() - status.at,
                               at=time.perf_counter())


def _line(status: progress.Status) -> str:
    head = "interrupted, verifying the best so far (Ctrl-C again aborts)" if interrupted() \
        else "sweep" if status.unit == "point" else "synthesis"
    return f"{head}: {_now(status).text()}"


@contextmanager
def progress_view(mode: ProgressMode) -> Iterator[None]:
    """Show the synthesis progress inside the context as ``mode`` says."""
    if mode is ProgressMode.NONE:
        yield
        return
    if mode is ProgressMode.JSON:
        def event(status: progress.Status) -> None:
            click.echo(json.dumps({"progress": status.as_json()}))

        with progress.reporting(event):
            yield
        return
    if mode is ProgressMode.LIVE:
        with _live():
            yield
        return
    with _lines():
        yield


@contextmanager
def _lines() -> Iterator[None]:
    """A line at each change of phase (or of the best value), and a heartbeat line when none was
    printed for :data:`HEARTBEAT` seconds."""
    last_time = [0.0]
    last_key = [""]
    lock = threading.Lock()
    stop = threading.Event()

    def emit(status: progress.Status) -> None:
        with lock:
            click.echo(_line(status), err=True)
            last_time[0] = time.perf_counter()

    def sink(status: progress.Status) -> None:
        key = f"{status.phase}|{status.memory}|{status.best}"
        if key != last_key[0]:
            last_key[0] = key
            emit(status)

    def beat() -> None:
        while not stop.wait(0.25):
            status = progress.current()
            if status is not None and time.perf_counter() - last_time[0] >= HEARTBEAT:
                emit(status)

    thread = threading.Thread(target=beat, name="posgmc-progress", daemon=True)
    with progress.reporting(sink):
        thread.start()
        try:
            yield
        finally:
            stop.set()
            thread.join()


@contextmanager
def _live() -> Iterator[None]:
    """rich's live display on stderr, refreshed four times a second (it disappears when done)."""
    from rich.console import Console
    from rich.live import Live
    from rich.text import Text

    class _Status:
        def __rich__(self) -> Text:
            status = progress.current()
            return Text("" if status is None or _HOLD[0] else _line(status), style="dim")

    def sink(status: progress.Status) -> None:
        _HOLD[0] = False
        if status.unit == "point" and _LIVE:
            # a completed point of a sweep or front stays on the screen, above the live line
            _LIVE[-1].console.print(Text(_line(status)), highlight=False)

    console = Console(stderr=True)
    # results printed on a terminal's stdout meanwhile go above the status line; a redirected
    # stdout is left alone
    with Live(_Status(), console=console, refresh_per_second=4, transient=True,
              redirect_stdout=_stdout_is_terminal(), redirect_stderr=False) as live:
        _LIVE.append(live)
        try:
            with progress.reporting(sink):
                yield
        finally:
            _LIVE.remove(live)
            _HOLD[0] = False
