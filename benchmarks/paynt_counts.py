"""Record what Storm builds from the PAYNT models vendored under ``tests/data/paynt/models``, as the
reference counts of ``tests/compiler/test_paynt_models.py``.

Run it with the reference environment (stormpy 2.0.0), never with posgmc's:

    $POSGMC_REFERENCE_PYTHON benchmarks/paynt_counts.py        # from the checkout's root

Every model file (PRISM-language ``sketch.templ``/``.prism``/``.pm``/``.nm``, or DRN) is built
with Storm's sparse builder and state valuations on: with them Storm checks that every assignment
stays in its variable's range (without them it does not, and builds a model of garbled states, as
for PAYNT's ``dodge6-lines``, where it reports 1340 states). A file Storm refuses records Storm's
message under ``error``. PAYNT sketches with holes are left out (Storm builds no family). Each model
is built in a child process with a time limit, so that a crash loses one model only. The result is
written as JSON (sorted keys, indent 1) to ``tests/data/paynt/storm_counts.json`` with a header
saying how and when it was made.
"""

from __future__ import annotations

import argparse
import datetime
import importlib.metadata
import json
import platform
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
DATA = HERE.parent / "tests" / "data" / "paynt"
SUFFIXES = (".templ", ".prism", ".pm", ".nm", ".drn")

_CHILD = r"""
import json, sys
import stormpy
path = sys.argv[1]
head = open(path).read(2000).lstrip()
try:
    if head.startswith("@type") or "\n@type" in head:
        m = stormpy.build_model_from_drn(path)
    else:
        program = stormpy.parse_prism_program(path)
        options = stormpy.BuilderOptions()
        options.set_build_state_valuations(True)
        m = stormpy.build_model(program, options=options)
    out = {"states": m.nr_states, "choices": m.nr_choices, "transitions": m.nr_transitions,
           "type": str(m.model_type).rsplit(".", 1)[-1].lower()}
    if hasattr(m, "nr_observations"):
        out["observations"] = m.nr_observations
except Exception as e:
    lines = [ln for ln in str(e).strip().splitlines() if ln.strip()]
    out = {"error": lines[-1] if lines else type(e).__name__}
print(json.dumps(out))
"""


def _is_sketch(path: Path) -> bool:
    return re.search(r"^\s*hole\s", path.read_text(errors="replace"), re.M) is not None


def record(models: Path, timeout: float) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for path in sorted(p for p in models.rglob("*") if p.suffix in SUFFIXES):
        if _is_sketch(path):
            continue
        key = path.relative_to(models).as_posix()
        try:
            done = subprocess.run([sys.executable, "-c", _CHILD, str(path)], capture_output=True,
                                  text=True, timeout=timeout, check=False)
            lines = done.stdout.strip().splitlines()
            crashed = {"error": f"crashed: {done.stderr[-200:]}"}
            out[key] = json.loads(lines[-1]) if lines else crashed
        except subprocess.TimeoutExpired:
            out[key] = {"error": f"no model within {timeout:g} s"}
        print(key, out[key], flush=True)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--models", type=Path, default=DATA / "models")
    parser.add_argument("--output", type=Path, default=DATA / "storm_counts.json")
    parser.add_argument("--timeout", type=float, default=300.0)
    args = parser.parse_args()
    header = {
        "command": "benchmarks/paynt_counts.py",
        "date": datetime.date.today().isoformat(),
        "stormpy": importlib.metadata.version("stormpy"),
        "python": platform.python_version(),
        "machine": f"{platform.system()} {platform.machine()}",
        "builder": "stormpy.build_model / build_model_from_drn, state valuations on",
    }
    data = {"header": header, "models": record(args.models, args.timeout)}
    args.output.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    main()
