"""Numerical engines on explicit models: graph precomputation, value/interval iteration, products."""
