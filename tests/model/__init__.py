"""Tests of posgmc.model: the compiled model record."""
