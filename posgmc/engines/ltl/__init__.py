"""LTL: atoms, syntactic co-safety, DFA by progression for co-safe formulas, LDBA for the others,
and the products with a model.

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
from posgmc.engines.ltl.ldba import Ldba, to_ldba
from posgmc.engines.ltl.omega import (
    OmegaProduct,
    accepting_cycles,
    accepting_end_components,
    omega_product,
)
from posgmc.engines.ltl.product import Product, letter_graph, pack_letters, product

__all__ = [
    "MAX_ALPHABET_ATOMS",
    "Dfa",
    "Ldba",
    "LetterGraph",
    "OmegaProduct",
    "Product",
    "accepting_cycles",
    "accepting_end_components",
    "check_atoms",
    "extract_atoms",
    "is_cosafe",
    "letter_graph",
    "minimise",
    "omega_product",
    "pack_letters",
    "product",
    "to_dfa",
    "to_ldba",
]
