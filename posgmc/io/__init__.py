"""Explicit model formats: Storm's DRN (import/export), PRISM explicit files and DOT (export)."""
