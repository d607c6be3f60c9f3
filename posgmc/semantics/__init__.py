"""Front end, second stage: one pass per semantic question (constants, names, types, players,
observations), ending in the instantiated :class:`~posgmc.semantics.flat.FlatModel`."""
