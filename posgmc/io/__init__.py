"""Explicit model formats: Storm's DRN (import/export), PRISM explicit files and DOT (export)."""

from __future__ import annotations

from posgmc.io.dot import dot_text, write_dot
from posgmc.io.drn import drn_text, parse_drn, read_drn, write_drn
from posgmc.io.prism_explicit import prism_explicit_texts, write_prism_explicit

__all__ = [
    "read_drn",
    "parse_drn",
    "write_drn",
    "drn_text",
    "write_prism_explicit",
    "prism_explicit_texts",
    "write_dot",
    "dot_text",
]
