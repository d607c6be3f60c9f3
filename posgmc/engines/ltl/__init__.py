"""Co-safe LTL: atoms, syntactic co-safety, DFA by progression, and the product with a model.

Typical use (the caller evaluates the atoms over the model)::

    atoms = extract_atoms(query.path)
    dfa = to_dfa(query.path, atoms)                # UnsupportedError if not co-safe
    prod = product(model, dfa, atom_values)        # atom_values: bool[len(atoms), S]
    # reachability of prod.accepting in prod.model; map back with prod.initial_map
"""

from __future__ import annotations

from posgmc.engines.ltl.cosafe import extract_atoms, is_cosafe
from posgmc.engines.ltl.dfa import Dfa, minimise, to_dfa
from posgmc.engines.ltl.product import Product, pack_letters, product

__all__ = [
    "Dfa",
    "Product",
    "extract_atoms",
    "is_cosafe",
    "minimise",
    "pack_letters",
    "product",
    "to_dfa",
]
