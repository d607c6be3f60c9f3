"""Finite-state strategies: objects, files, products with a model, and their verified values."""
