"""Storm's explicit DRN format: read a file into an :class:`ExplicitModel`, write one back.

The format, as Storm 2.0 reads it (``storm-parsers/parser/DirectEncodingParser.cpp``) and writes it
(``storm/io/DirectEncodingExporter.cpp``), extended with PAYNT's partially observable games::

    // comment lines (anywhere)
    @type: POSMG                    DTMC | MDP | POMDP | SMG | POSMG
    @value_type: double             optional: double | rational
    @parameters
                                    (the next line: parameter names; must be empty here)
    @placeholders                   optional: lines "$name : value" until the next "@" line
    @reward_models
    steps cost                      (the next line: names split at single spaces/tabs)
    @nr_states
    3
    @nr_choices
    4
    @model
    state 0 {2} <1> [1, 0] init "two words"
    //[x=0	& y=1]                  optional state valuation (Storm writes one when it has them)
    	action a [0, 2.5]
    		1 : 0.5
    		2 : 1/2
    ...

This package is the public API (:func:`read_drn`, :func:`parse_drn`, :func:`write_drn`,
:func:`drn_text`); its modules, each with one job, in the order a read goes through them:

* :mod:`.source`: the text being read, and the errors that point into it (line and column);
* :mod:`.header`: the header, every line before ``@model``;
* :mod:`.body`: the lines after ``@model`` in bulk (classified; state and action lines parsed
  with vectorized numpy string operations);
* :mod:`.lines`: the per-line parsers of state and action lines, which define the syntax and the
  error positions (the slow path for irregular lines and for every error);
* :mod:`.transitions`: the choice structure and the transition matrix;
* :mod:`.rewards`: the reward models;
* :mod:`.reader`: :func:`read_drn` and :func:`parse_drn`, and how DRN maps onto the model;
* :mod:`.writer`: :func:`write_drn` and :func:`drn_text`.
"""

from __future__ import annotations

from posgmc.io.drn.reader import parse_drn, read_drn
from posgmc.io.drn.writer import drn_text, write_drn

__all__ = ["read_drn", "parse_drn", "write_drn", "drn_text"]
