"""Co-safe LTL: atoms, syntactic co-safety, DFA by progression, and the product with a model.

Typical use (the caller evaluates the atoms over the model)::

    atoms = extract_atoms(query.path)
    # atom_values: bool[len(atoms), S]; the automaton reads only the model's letters
    dfa = to_dfa(query.path, atoms, alphabet=letter_graph(model, atom_values))
    prod = product(model, dfa, atom_values)        # UnsupportedError above if not co-safe
    # reachability of prod.accepting in prod.model; map back with prod.initial_map
"""

from __future__ import annotations

from posgmc.engines.ltl.cosafe import extract_atoms, is_cosafe
from posgmc.engines.ltl.dfa import (
    MAX_ALPHABET_ATOMS,
    Dfa,
    LetterGraph,
    check_atoms,
    minimise,
    to_dfa,
)
from posgmc.engines.ltl.product import Product, letter_graph, pack_letters, product

__all__ = [
    "MAX_ALPHABET_ATOMS",
    "Dfa",
    "LetterGraph",
    "Product",
    "check_atoms",
    "extract_atoms",
    "is_cosafe",
    "letter_graph",
    "minimise",
    "pack_letters",
    "product",
    "to_dfa",
]
