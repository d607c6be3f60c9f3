"""The frozen compiled game (numpy/scipy only)."""
