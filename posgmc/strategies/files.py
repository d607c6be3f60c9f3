"""Strategy files: the ``posgmc-fss/1`` JSON format, read and written exactly.

::

    {"format": "posgmc-fss/1", "player": "rover", "memory_size": 2, "initial_memory": 0,
     "observables": ["pos"],
     "rules": [
       {"memory": 0, "observation": {"pos": 0}, "action": {"via1": 0.7, "via2": 0.3},
        "update": {"via1": {"0": 1.0}, "via2": {"1": 1.0}}},
       {"memory": 1, "observation": {"pos": 0}, "action": {"via2": 1.0}}
     ]}

* ``player``: the player's name (``""`` for the agent of a model without players);
* ``observables``: the player's observables in declaration order (all state variables for a
  player that observes everything; ``[]`` for a model read from DRN, whose observations are
  then given by their ids, ``"observation": 3``);
* a rule: ``memory`` n, ``observation`` z (the observables' values: JSON ``true``/``false`` for a
  Boolean observable, integers otherwise), ``action`` γ(n, z) as label → probability, and
  optionally ``update`` δ(n, z, a) as label → {node → probability}; an action without an update
  keeps the memory node;
* every distribution sums to 1 within 1e-9; one rule per (memory, observation).

Every error names the file and the JSON path of what is wrong (``rules[3].action.via1``), or the
line and column for text that is not JSON. Writing sorts rules by memory and observation, and
actions by label, and prints probabilities with ``repr``, so reading a written file gives back the
same arrays.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from posgmc.errors import InputError, SourceSpan, SourceText
from posgmc.strategies.fss import (
    MAX_MEMORY_SIZE,
    PROBABILITY_TOLERANCE,
    FiniteStateStrategy,
    StrategyError,
)

__all__ = ["FORMAT", "read_strategy", "read_strategies", "parse_strategy", "strategy_from_json",
           "strategy_to_json", "write_strategy", "dump_strategy", "is_memoryless_document",
           "memoryless_players", "read_strategy_for", "write_memoryless_strategy",
           "rules_in_order"]

FORMAT = "posgmc-fss/1"
_TOP_KEYS = {"format", "player", "memory_size", "initial_memory", "observables", "rules"}
_RULE_KEYS = {"memory", "observation", "action", "update"}


def read_strategy(path: str | Path, *, player: str | None = None) -> FiniteStateStrategy:
    """Read a strategy file: ``posgmc-fss/1``, or the memoryless strategy that ``check
    --export-strategy`` writes for a fully observable model (``player``: whose, when it holds
    several players' choices).

    Raises:
        InputError: the file cannot be read, or is not JSON (with line and column).
        StrategyError: the JSON is not a valid ``posgmc-fss/1`` strategy (with its JSON path).
    """
    from posgmc.io.reading import read_text

    name = str(path)
    text = read_text(path)
    return parse_strategy(text, file=name, player=player)


def read_strategy_for(path: str | Path, model: Any, *,
                      player: str | None = None) -> FiniteStateStrategy:
    """:func:`read_strategy` with the model the strategy is for at hand: a memoryless strategy
    file then becomes exactly the strategy it was exported as — each listed state plays its
    ``choice`` — and a state where it did not choose (no decision mattered there) its first
    choice, as :func:`~posgmc.strategies.binding.memoryless_strategy` does.

    Raises:
        StrategyError: as :func:`read_strategy`, or the file's states are not the model's (another
            model, or other constants), or its choices are not the player's.
    """
    from posgmc.io.reading import read_text
    from posgmc.strategies.binding import memoryless_strategy

    name = str(path)
    doc = _json(read_text(path), name)
    if not is_memoryless_document(doc):
        return strategy_from_json(doc, file=name, player=player)
    whose = _whose(doc, player, name)
    names = list(model.player_names)
    if whose and whose not in names:
        raise _fail(f"{whose!r} is not a player of the model ({', '.join(names)})",
                    "states", name)
    index = names.index(whose) if whose else 0
    choices = np.full(model.num_states, -1, dtype=np.int64)
    variables = list(model.variable_names)
    for i, entry in enumerate(doc["states"]):
        if entry.get("player", "") != whose:
            continue
        where = f"states[{i}]"
        for key in ("state", "action"):
            if key not in entry:
                raise _fail(f"the field {key!r} is missing", f"{where}.{key}", name)
        s = _int(entry["state"], f"{where}.state", name, "state")
        c = _int(entry.get("choice", -1), f"{where}.choice", name, "choice")
        if not 0 <= s < model.num_states:
            raise _fail(f"state {s} is not a state of the model (0..{model.num_states - 1})",
                        f"{where}.state", name, hint="export and use it with the same model "
                        "and constants")
        valuation = entry.get("valuation")
        if valuation is not None and (list(valuation) != variables or list(valuation.values())
                                      != [int(v) for v in model.state_values[s]]):
            raise _fail(f"state {s} is {model.describe_state(s)} in the model, not {valuation}",
                        f"{where}.valuation", name, hint="export and use it with the same model "
                        "and constants")
        first, end = int(model.row_groups[s]), int(model.row_groups[s + 1])
        if not 0 <= c < end - first:
            raise _fail(f"state {s} has no choice {c} (it has {end - first})", f"{where}.choice",
                        name)
        if model.action_names[int(model.choice_actions[first + c])] != entry["action"]:
            raise _fail(f"choice {c} of state {s} is not labelled {entry['action']!r}",
                        f"{where}.action", name)
        choices[s] = first + c
    return dataclasses.replace(memoryless_strategy(model, index, choices), source=name)


def read_strategies(path: str | Path) -> tuple[FiniteStateStrategy, ...]:
    """Every strategy a file holds: the one of a ``posgmc-fss/1`` file, or each deciding
    player's of a memoryless strategy file (see :func:`read_strategy`)."""
    from posgmc.io.reading import read_text

    name = str(path)
    doc = _json(read_text(path), name)
    if is_memoryless_document(doc):
        return tuple(strategy_from_json(doc, file=name, player=p)
                     for p in memoryless_players(doc, file=name))
    return (strategy_from_json(doc, file=name),)


def _json(text: str, file: str | None) -> Any:
    try:
        return json.loads(text, parse_int=_parse_int)
    except json.JSONDecodeError as e:
        error = InputError(f"not valid JSON: {e.msg}", SourceSpan(e.lineno, e.colno, file=file))
        raise error.with_source(SourceText(text, file)) from None
    except RecursionError:
        raise InputError(f"{file or 'strategy'}: the JSON nests too deeply to be a strategy file",
                         hint="a strategy file nests five levels deep") from None


def parse_strategy(text: str, *, file: str | None = None,
                   player: str | None = None) -> FiniteStateStrategy:
    """A strategy from the text of a strategy file (see :func:`read_strategy`)."""
    return strategy_from_json(_json(text, file), file=file, player=player)


class _HugeInt(str):
    """A JSON integer with more digits than any field of a strategy can hold (kept as its text,
    so that Python's 4300-digit limit on ``int()`` is never reached and the field's check reports
    it with its JSON path)."""


_DIGITS = 40
"""Integers with more digits than this are beyond 64 bits, and are never converted."""


def _parse_int(text: str) -> int | _HugeInt:
    return _HugeInt(text) if len(text.lstrip("-")) > _DIGITS else int(text)


def _shown(value: Any) -> str:
    """``value`` as JSON for a message, cut to about 60 characters."""
    text = str(value) if isinstance(value, _HugeInt) else json.dumps(value)
    if len(text) > 60:
        return f"{text[:40]}... ({len(text)} characters)"
    return text


def _fail(message: str, path: str, file: str | None, hint: str | None = None) -> StrategyError:
    return StrategyError(message, path=path, file=file, hint=hint)


_INT64 = (-(1 << 63), (1 << 63) - 1)


def _int(value: Any, path: str, file: str | None, what: str) -> int:
    if isinstance(value, _HugeInt) or (
        isinstance(value, int) and not _INT64[0] <= value <= _INT64[1]
    ):
        raise _fail(f"{what} {_shown(value)} is beyond 64-bit integers", path, file)
    if isinstance(value, bool) or not isinstance(value, int):
        raise _fail(f"{what} must be an integer, got {_shown(value)}", path, file)
    return value


def _probability(value: Any, path: str, file: str | None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or not 0.0 <= value <= 1.0:
        raise _fail(
            f"a probability must be a number in [0, 1], got {_shown(value)}", path, file
        )
    return float(value)


def _distribution(value: Any, path: str, file: str | None, what: str) -> dict[str, float]:
    if not isinstance(value, dict) or not value:
        raise _fail(f"{what} must be a non-empty object of probabilities", path, file)
    out = {str(k): _probability(v, _child(path, str(k)), file) for k, v in value.items()}
    total = math.fsum(out.values())
    if abs(total - 1.0) > PROBABILITY_TOLERANCE:
        raise _fail(f"the probabilities of {what} sum to {total!r}, not 1", path, file)
    return out


def _key(name: str) -> str:
    """A JSON object key for a message, cut when it is very long."""
    return name if len(name) <= 60 else f"{name[:40]}...({len(name)} characters)"


def _child(path: str, key: str) -> str:
    """The JSON path of member ``key`` of the object at ``path``: ``rules[0].action.fwd``, or
    ``["a b"]`` for a key that is empty or not a plain name."""
    shown = _key(key)
    if key and all(c.isalnum() or c in "_-" for c in key):
        return f"{path}.{shown}" if path else shown
    return f"{path}[{json.dumps(shown)}]"


def is_memoryless_document(doc: Any) -> bool:
    """Whether ``doc`` is a model checker's memoryless strategy (``check --export-strategy`` on a
    fully observable model: ``{"property", "memoryless": true, "states": [...]}``, see
    :func:`write_memoryless_strategy`) rather than a ``posgmc-fss/1`` document."""
    return isinstance(doc, dict) and doc.get("memoryless") is True and "states" in doc \
        and "format" not in doc


def memoryless_players(doc: Any, *, file: str | None = None) -> list[str]:
    """The players who choose in a memoryless strategy document, in order of appearance (``[""]``
    for a model without players)."""
    states = doc.get("states")
    if not isinstance(states, list):
        raise _fail("states must be a list", "states", file)
    players: dict[str, None] = {}
    for i, entry in enumerate(states):
        if not isinstance(entry, dict):
            raise _fail("a state's entry must be an object", f"states[{i}]", file)
        player = entry.get("player", "")
        if not isinstance(player, str):
            raise _fail("player must be a string (a player's name)", f"states[{i}].player", file)
        players.setdefault(player, None)
    return list(players) or [""]


def _whose(doc: Any, player: str | None, file: str | None) -> str:
    """The player whose strategy is read from a memoryless strategy document: ``player``, or the
    only one who chooses in it."""
    players = memoryless_players(doc, file=file)
    if player is None:
        if len(players) > 1:
            raise _fail(f"the file holds the strategies of players {', '.join(map(repr, players))}"
                        ": say whose", "states", file, hint="--strategy PLAYER=FILE")
        return players[0]
    if player not in players:
        raise _fail(f"the file holds no strategy of player {player!r} (it has "
                    f"{', '.join(map(repr, players))})", "states", file)
    return player


def _memoryless_as_fss(doc: dict[str, Any], player: str | None,
                       file: str | None) -> tuple[dict[str, Any], list[int]]:
    """A memoryless strategy document as the ``posgmc-fss/1`` document of one player's strategy
    with one memory node: the player sees the whole state (its observables are the state
    variables, in the file's order; without variables, the state's index), and plays the entry's
    action there."""
    player = _whose(doc, player, file)
    rules: list[dict[str, Any]] = []
    index: list[int] = []
    observables: list[str] | None = None
    for i, entry in enumerate(doc["states"]):
        if entry.get("player", "") != player:
            continue
        for key in ("state", "action"):
            if key not in entry:
                raise _fail(f"the field {key!r} is missing", f"states[{i}].{key}", file)
        valuation = entry.get("valuation")
        if valuation is not None and not isinstance(valuation, dict):
            raise _fail("valuation must be an object: variable -> value",
                        f"states[{i}].valuation", file)
        names = list(valuation) if valuation is not None else []
        if observables is None:
            observables = names
        elif names != observables:
            raise _fail("every state's valuation must name the same variables",
                        f"states[{i}].valuation", file)
        rules.append({"memory": 0, "observation": valuation if valuation is not None
                      else entry["state"], "action": {entry["action"]: 1.0}})
        index.append(i)
    return {"format": FORMAT, "player": player, "memory_size": 1, "initial_memory": 0,
            "observables": observables or [], "rules": rules}, index


def strategy_from_json(doc: Any, *, file: str | None = None,
                       player: str | None = None) -> FiniteStateStrategy:
    """A strategy from a parsed ``posgmc-fss/1`` document, or from a model checker's memoryless
    strategy (:func:`is_memoryless_document`): then ``player``'s strategy, with one memory node
    (``player`` None: the only player who chooses in it).

    Time and memory are linear in the document's size (the memory size only bounds the nodes
    rules may name).

    Raises:
        StrategyError: with the JSON path of the first problem.
    """
    if is_memoryless_document(doc):
        converted, index = _memoryless_as_fss(doc, player, file)
        try:
            return strategy_from_json(converted, file=file)
        except StrategyError as e:  # its rules are the file's states: say which
            found = re.match(r"rules\[(\d+)\](.*)", e.path or "")
            if found is None:
                raise
            where = f"states[{index[int(found.group(1))]}]"
            prefix = ": ".join(x for x in (file, e.path) if x) + ": "
            raise _fail(e.message.removeprefix(prefix), where, file, hint=e.hint) from None
    if not isinstance(doc, dict):
        raise _fail("a strategy file holds one JSON object", "$", file)
    for key in doc:
        if key not in _TOP_KEYS:
            raise _fail(
                f"unknown field {_key(key)!r} (fields: {', '.join(sorted(_TOP_KEYS))})",
                _child("", key), file
            )
    if doc.get("format") != FORMAT:
        raise _fail(
            f"format must be {FORMAT!r}, got {_shown(doc.get('format'))}", "format", file
        )
    for key in ("player", "memory_size", "observables", "rules"):
        if key not in doc:
            raise _fail(f"the field {key!r} is missing", key, file)
    player = doc["player"]
    if not isinstance(player, str):
        raise _fail("player must be a string (a player's name)", "player", file)
    k = _int(doc["memory_size"], "memory_size", file, "memory_size")
    if k < 1:
        raise _fail(f"memory_size must be at least 1, got {k}", "memory_size", file)
    if k > MAX_MEMORY_SIZE:
        raise _fail(f"memory_size {k} is more than the largest supported, {MAX_MEMORY_SIZE}",
                    "memory_size", file)
    n_init = _int(doc.get("initial_memory", 0), "initial_memory", file, "initial_memory")
    if not 0 <= n_init < k:
        raise _fail(
            f"initial_memory {n_init} is not a memory node (0..{k - 1})", "initial_memory", file
        )
    observables = doc["observables"]
    if not isinstance(observables, list) or not all(isinstance(o, str) for o in observables):
        raise _fail("observables must be a list of names", "observables", file)
    if len(set(observables)) != len(observables):
        raise _fail("observables must be distinct", "observables", file)
    rules = doc["rules"]
    if not isinstance(rules, list):
        raise _fail("rules must be a list", "rules", file)

    obs_index: dict[tuple[int, ...], int] = {}
    boolean = [False] * len(observables)
    act_index: dict[str, int] = {}
    seen: dict[tuple[int, int], int] = {}
    rule_memory: list[int] = []
    rule_obs: list[int] = []
    entry_rule: list[int] = []
    entry_action: list[int] = []
    entry_prob: list[float] = []
    update_entry: list[int] = []
    update_node: list[int] = []
    update_prob: list[float] = []
    for i, rule in enumerate(rules):
        here = f"rules[{i}]"
        if not isinstance(rule, dict):
            raise _fail("a rule must be an object", here, file)
        for key in rule:
            if key not in _RULE_KEYS:
                raise _fail(
                    f"unknown field {_key(key)!r} (fields: {', '.join(sorted(_RULE_KEYS))})",
                    _child(here, key), file
                )
        for key in ("memory", "observation", "action"):
            if key not in rule:
                raise _fail(f"the field {key!r} is missing", f"{here}.{key}", file)
        n = _int(rule["memory"], f"{here}.memory", file, "memory")
        if not 0 <= n < k:
            raise _fail(f"memory {n} is not a memory node (0..{k - 1})", f"{here}.memory", file)
        z_values = _observation(
            rule["observation"], observables, boolean, f"{here}.observation", file
        )
        z = obs_index.setdefault(z_values, len(obs_index))
        if (n, z) in seen:
            raise _fail(f"a second rule for memory {n} and this observation (the first is "
                        f"rules[{seen[n, z]}])", here, file)
        seen[n, z] = i
        rule_memory.append(n)
        rule_obs.append(z)
        action = _distribution(rule["action"], f"{here}.action", file, "the action")
        update = rule.get("update", {})
        if not isinstance(update, dict):
            raise _fail("update must be an object: action -> {node: probability}",
                        f"{here}.update", file)
        for label in update:
            if label not in action:
                raise _fail(f"an update for action {_key(label)!r}, which the rule does not play",
                            _child(f"{here}.update", label), file)
        for label, prob in action.items():
            entry = len(entry_rule)
            entry_rule.append(i)
            entry_action.append(act_index.setdefault(label, len(act_index)))
            entry_prob.append(prob)
            if label not in update:
                update_entry.append(entry)
                update_node.append(n)
                update_prob.append(1.0)
                continue
            upath = _child(f"{here}.update", label)
            nodes = _distribution(update[label], upath, file, f"the update of {_key(label)!r}")
            for node, q in nodes.items():
                m = int(node) if node.isascii() and node.isdigit() and len(node) <= _DIGITS \
                    else -1
                if str(m) != node or not 0 <= m < k:
                    raise _fail(f"{_key(node)!r} is not a memory node (0..{k - 1})",
                                _child(upath, node), file)
                update_entry.append(entry)
                update_node.append(m)
                update_prob.append(q)

    Z = len(obs_index)
    values = np.array(list(obs_index), dtype=np.int64).reshape(Z, max(len(observables), 1))
    return FiniteStateStrategy.from_entries(
        player=player,
        memory_size=k,
        initial_memory=n_init,
        observables=tuple(observables),
        observation_values=values,
        actions=tuple(act_index),
        rule_memory=np.array(rule_memory, dtype=np.int64),
        rule_observation=np.array(rule_obs, dtype=np.int64),
        entry_rule=np.array(entry_rule, dtype=np.int64),
        entry_action=np.array(entry_action, dtype=np.int64),
        entry_probability=np.array(entry_prob, dtype=np.float64),
        update_entry=np.array(update_entry, dtype=np.int64),
        update_node=np.array(update_node, dtype=np.int64),
        update_probability=np.array(update_prob, dtype=np.float64),
        boolean=tuple(boolean) if any(boolean) else (),
        source=file,
        rule_source=np.arange(len(rules), dtype=np.int64),
    )


def _observation(value: Any, observables: list[str], boolean: list[bool], path: str,
                 file: str | None) -> tuple[int, ...]:
    if not observables:
        if isinstance(value, bool) or not isinstance(value, (int, _HugeInt)) or (
            isinstance(value, int) and value < 0
        ):
            raise _fail("with no observables (a model read from DRN) an observation is its id, a "
                        f"non-negative integer; got {_shown(value)}", path, file)
        return (_int(value, path, file, "the observation id"),)
    if not isinstance(value, dict):
        raise _fail("an observation must be an object: observable -> value", path, file)
    for key in value:
        if key not in observables:
            raise _fail(f"{_key(key)!r} is not one of the observables ({', '.join(observables)})",
                        _child(path, key), file)
    out = []
    for j, name in enumerate(observables):
        if name not in value:
            raise _fail(f"the observable {name!r} has no value", path, file)
        v = value[name]
        if isinstance(v, bool):
            boolean[j] = True
            out.append(int(v))
        elif isinstance(v, (int, _HugeInt)):
            out.append(_int(v, f"{path}.{name}", file, f"the value of {name!r}"))
        else:
            raise _fail(f"an observable's value must be an integer or true/false, got "
                        f"{_shown(v)}", f"{path}.{name}", file)
    return tuple(out)


def rules_in_order(fss: FiniteStateStrategy) -> np.ndarray:
    """int64[R]: the strategy's rules sorted by memory node, then by observation values."""
    Z = fss.num_observations
    rank = np.empty(Z, dtype=np.int64)
    if Z:
        rank[np.lexsort(fss.observation_values.T[::-1])] = np.arange(Z)
    return np.lexsort((rank[fss.rule_observation], fss.rule_memory)).astype(np.int64)


def _rule_json(fss: FiniteStateStrategy, r: int, boolean: tuple[bool, ...]) -> dict[str, Any]:
    n, z = int(fss.rule_memory[r]), int(fss.rule_observation[r])
    row = fss.observation_values[z].tolist()
    if fss.observables:
        observation: Any = {
            name: (bool(v) if b else int(v)) for name, v, b in zip(fss.observables, row, boolean)
        }
    else:
        observation = int(row[0])
    entries = sorted(range(int(fss.choice_start[r]), int(fss.choice_start[r + 1])),
                     key=lambda e: fss.actions[int(fss.choice_action[e])])
    rule: dict[str, Any] = {
        "memory": n,
        "observation": observation,
        "action": {fss.actions[int(fss.choice_action[e])]: float(fss.choice_probability[e])
                   for e in entries},
    }
    update = {}
    for e in entries:
        lo, hi = int(fss.update_start[e]), int(fss.update_start[e + 1])
        nodes = fss.update_node[lo:hi].tolist()
        if not (nodes == [n] and fss.update_probability[lo] == 1.0):
            update[fss.actions[int(fss.choice_action[e])]] = {
                str(m): float(q) for m, q in zip(nodes, fss.update_probability[lo:hi].tolist())
            }
    if update:
        rule["update"] = update
    return rule


def strategy_to_json(fss: FiniteStateStrategy) -> dict[str, Any]:
    """The ``posgmc-fss/1`` document of a strategy (rules sorted by memory, then observation)."""
    boolean = fss.boolean or (False,) * len(fss.observables)
    return {
        "format": FORMAT,
        "player": fss.player,
        "memory_size": fss.memory_size,
        "initial_memory": fss.initial_memory,
        "observables": list(fss.observables),
        "rules": [_rule_json(fss, r, boolean) for r in rules_in_order(fss).tolist()],
    }


def dump_strategy(fss: FiniteStateStrategy) -> str:
    """The text of a strategy file: one rule per line, so that diffs stay readable."""
    doc = strategy_to_json(fss)
    head = {k: v for k, v in doc.items() if k != "rules"}
    lines = [json.dumps(r) for r in doc["rules"]]
    body = ",\n  ".join(lines)
    return json.dumps(head)[:-1] + ',\n "rules": [\n  ' + body + "\n ]}\n"


def write_strategy(fss: FiniteStateStrategy, path: str | Path) -> None:
    """Write a strategy file atomically (a reader never sees half a file)."""
    from posgmc.io.atomic import atomic_write_text

    atomic_write_text(str(path), dump_strategy(fss))


def write_memoryless_strategy(path: str | Path, property_text: str, model: Any,
                              strategy: Any) -> None:
    """A model checker's memoryless strategy (one choice per deciding state, -1 elsewhere) as JSON,
    one line per deciding state, written as it is encoded: a large game's strategy never exists as
    one document in memory (indented ``json.dumps`` runs the pure-Python encoder over the whole
    document)."""
    from posgmc.io.atomic import atomic_open

    m = model
    strategy = np.asarray(strategy)
    # only the states where the strategy chooses; their fields gathered as whole arrays
    chosen = np.flatnonzero(strategy >= 0)
    choices = strategy[chosen]
    local = (choices - m.row_groups[chosen]).tolist()
    actions = m.choice_actions[choices].tolist()
    names = list(m.variable_names)
    values = m.state_values[chosen].tolist() if names else None
    players = m.state_players[chosen].tolist() if m.player_names else None
    encode = json.JSONEncoder().encode  # compact, C-accelerated
    with atomic_open(path) as handle:
        handle.write(
            '{"property": ' + encode(property_text) + ', "memoryless": true, '
            '"states": ['
        )
        for i, (s, c, a) in enumerate(zip(chosen.tolist(), local, actions)):
            entry: dict[str, object] = {"state": s, "choice": c, "action": m.action_names[a]}
            if values is not None:
                entry["valuation"] = dict(zip(names, values[i]))
            if players is not None:
                entry["player"] = m.player_names[players[i]]
            handle.write(("\n  " if i == 0 else ",\n  ") + encode(entry))
        handle.write("\n]}\n")
