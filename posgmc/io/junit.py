"""JUnit XML reports (one test case per property), the format CI systems read."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from posgmc.io.atomic import atomic_write_text

__all__ = ["Case", "write_junit"]


@dataclass(frozen=True)
class Case:
    """One test case: ``failure`` is the message of a failed case, ``error`` of one that could not
    be checked, ``skipped`` a reason not to count it."""

    name: str
    classname: str
    seconds: float = 0.0
    failure: str | None = None
    error: str | None = None
    skipped: str | None = None


def write_junit(path: str | Path, suite: str, cases: Sequence[Case]) -> None:
    """Write ``cases`` as one ``<testsuite>`` (atomically)."""
    root = ET.Element("testsuites")
    node = ET.SubElement(root, "testsuite", {
        "name": suite,
        "tests": str(len(cases)),
        "failures": str(sum(c.failure is not None for c in cases)),
        "errors": str(sum(c.error is not None for c in cases)),
        "skipped": str(sum(c.skipped is not None for c in cases)),
        "time": f"{sum(c.seconds for c in cases):.6f}",
    })
    for c in cases:
        case = ET.SubElement(node, "testcase", {"name": c.name, "classname": c.classname,
                                                "time": f"{c.seconds:.6f}"})
        if c.failure is not None:
            ET.SubElement(case, "failure", {"message": c.failure}).text = c.failure
        if c.error is not None:
            ET.SubElement(case, "error", {"message": c.error}).text = c.error
        if c.skipped is not None:
            ET.SubElement(case, "skipped", {"message": c.skipped})
    ET.indent(root)
    atomic_write_text(path, ET.tostring(root, encoding="unicode", xml_declaration=True) + "\n")
