"""Running a benchmark script's ``--worker`` mode in a fresh interpreter and reading its result.

Every benchmark measures in a child process (so that peak memory and start-up are its own) that
prints one JSON object as its last ``{``-line; this is the one place that starts it and reads it.
Not part of the ``posgmc`` package.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path
from typing import Any


def run_worker(script: Path, python: str, args: list[str], timeout: float) -> dict[str, Any]:
    """Run ``python script --worker *args``; its last JSON line, or ``{"error": ...}``.

    Args:
        script: the benchmark script (it must implement ``--worker``).
        python: the interpreter (posgmc's own, or the Storm reference environment's).
        args: the worker's arguments.
        timeout: seconds before the child is killed (``subprocess.TimeoutExpired`` propagates).
    """
    proc = subprocess.run(
        [python, str(script.resolve()), "--worker", *args],
        check=False,
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    lines = [line for line in proc.stdout.splitlines() if line.startswith("{")]
    if proc.returncode != 0 or not lines:
        tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or ["(no output)"]
        return {"error": tail[0]}
    return json.loads(lines[-1])  # type: ignore[no-any-return]
