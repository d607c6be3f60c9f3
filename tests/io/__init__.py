"""Tests of posgmc.io: DRN, PRISM explicit and DOT formats."""
