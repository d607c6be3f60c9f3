"""Where ``check --export-strategy`` writes: the destination checked before any work, and one
destination per property and constant point, so that no strategy overwrites another.

Two forms: a synthesised strategy (a ``pomdp``/``posg`` without ``--strategy`` and
``--full-observation``) goes to a directory, ``<player>.json`` per player; a model checker's
memoryless strategy goes to a file, in the same ``posgmc-fss/1`` format with one memory node: the
strategy of the query's coalition (``<<rover>>``: the rover's; the agent's on an mdp), so that
``check --strategy FILE`` gives back the number printed. A coalition of several players writes one
file per player, ``FILE-stem.<player>.json``. Where the choices cannot be said by the player's
observation and the action's label (``--full-observation`` on a posg: the player does not see
the whole state; two choices of one state with the same label), the file is the state-indexed
memoryless strategy (``"memoryless": true``), which every reader also accepts, and the message
says why. With one property and one constant point the destination is
the one given; with several properties or a ``--const`` sweep each property and point gets its
own: a subdirectory ``DIR/<property>/<point>/`` (directory form) or a file
``FILE-stem.<property>.<point>.json`` (file form), where ``<property>`` is the property's name
(``"name": P=? [...]``) or ``prop<i>`` (1-based, in the order checked) and ``<point>`` the swept
constants, ``N=5,p=0.5``.
"""

from __future__ import annotations

import os
import re
import stat
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from posgmc.errors import InputError

__all__ = ["Written", "check_destination", "coalition_players", "synthesises", "write_exports"]

OPTION = "--export-strategy"


@dataclass(frozen=True)
class Written:
    """A file written: its path, and what it holds when that needs saying (why it is not
    ``posgmc-fss/1``)."""

    path: str
    note: str | None = None


def synthesises(session: Any, *, given_strategies: bool, full_observation: bool) -> bool:
    """Whether ``check`` answers the loaded model by synthesis (so exports a directory): a
    partially observable model (by its type or its observables) without given strategies and
    without ``--full-observation``; read off the parsed model, before anything is built."""
    if given_strategies or full_observation:
        return False
    explicit = getattr(session, "explicit", None)
    if explicit is not None:
        return bool(explicit.model_type.is_partially_observable or explicit.observations)
    syntax = session.syntax
    if syntax is None:
        return False
    return bool(
        syntax.model_type.is_partially_observable
        or syntax.observables
        or any(getattr(m, "observables", ()) for m in syntax.modules)
    )


def check_destination(path: str, *, directory: bool, option: str = OPTION) -> None:
    """Refuse a destination that cannot be written, before any work: an empty name, an existing
    file where a directory goes (or a directory or device where a file goes), a path under a
    file, or a directory without write permission.

    Raises:
        InputError: naming ``option`` (``--export-strategy``) and the path.
    """
    if not path.strip():
        raise InputError(f"{option}: an empty path", hint="give a directory, e.g. "
                         f"{option} strategies/" if directory else "give a file, e.g. s.json")
    target = Path(path)
    what = "a directory" if directory else "a file"
    try:
        mode = target.stat().st_mode
    except FileNotFoundError:
        mode = None
    except OSError as e:  # e.g. a path under a file: ENOTDIR
        raise InputError(f"{option}: cannot write {path}: {e.strerror or e}") from None
    if mode is not None:
        if directory and not stat.S_ISDIR(mode):
            raise InputError(f"{option}: cannot write {path}: it exists and is not a "
                             "directory; synthesised strategies go into a directory, "
                             "<player>.json each",
                             hint="give a new or an existing directory")
        if not directory and stat.S_ISDIR(mode):
            raise InputError(f"{option}: cannot write {path}: it is a directory; a model "
                             "checker's memoryless strategy is written to a file",
                             hint="give a file name, e.g. strategy.json")
        if not directory and not stat.S_ISREG(mode):
            return  # a device or a pipe (/dev/stdout): written into, as it is
        writable = target if stat.S_ISDIR(mode) else (target.parent if str(target.parent) else
                                                       Path("."))
        _probe(writable, path, option)
        return
    # a new path: its nearest existing ancestor must be a writable directory
    ancestor = target.parent
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if not ancestor.exists():
        ancestor = Path(".")
    if not ancestor.is_dir():
        raise InputError(f"{option}: cannot write {path}: {ancestor} is not a directory")
    if not directory and ancestor != target.parent:
        raise InputError(f"{option}: cannot write {path}: no directory {target.parent}",
                         hint=f"create it first, or give {what} in an existing directory")
    _probe(ancestor, path, option)


def _probe(directory: Path, path: str, option: str) -> None:
    """Create and remove a file in ``directory``: what the writers will do (a file is written
    beside its destination and renamed), asked of the file system itself rather than guessed from
    permission bits (root passes those; /proc takes no new file).

    Raises:
        InputError: the directory takes no new file.
    """
    try:
        fd, tmp = tempfile.mkstemp(prefix=".posgmc-probe.", dir=directory)
    except OSError as e:
        raise InputError(f"{option}: cannot write {path}: no new file can be created in "
                         f"{directory} ({e.strerror or e})") from None
    os.close(fd)
    os.unlink(tmp)


_UNSAFE = re.compile(r"[^A-Za-z0-9_.,=+-]")


def _part(text: str) -> str:
    """A file-name part: characters other than letters, digits and ``_.,=+-`` become ``_``."""
    cleaned = _UNSAFE.sub("_", text).strip(".")
    return cleaned or "_"


def _labels(index: int, name: str | None, several_properties: bool,
            point: Mapping[str, str]) -> list[str]:
    parts = []
    if several_properties:
        parts.append(_part(name) if name else f"prop{index + 1}")
    if point:
        parts.append(_part(",".join(f"{n}={v}" for n, v in point.items())))
    return parts


def destination(root: str, *, directory: bool, index: int, name: str | None,
                several_properties: bool, point: Mapping[str, str]) -> str:
    """Where the strategy of property ``index`` (0-based; ``name`` when it is named) at constant
    ``point`` (the swept constants' values as text, empty without a sweep) goes."""
    parts = _labels(index, name, several_properties, point)
    if directory:
        return os.path.join(root, *parts)
    if not parts:
        return root
    base, ext = os.path.splitext(root)
    return base + "." + ".".join(parts) + (ext or ".json")


def write_exports(root: str, report: Any, *, point: Mapping[str, str],
                  several_points: bool, zero_based_players: bool = False) -> list[Written]:
    """Write the strategies of one report (one constant point) under ``root``; the files written.

    A synthesised result's strategies go to ``<player>.json`` in its directory (a second strategy
    of the same player, the composed defence that ``vs_fss_adversary`` is about, to
    ``<player>.vs_fss.json``); otherwise each property's memoryless strategy, as the coalition's
    ``posgmc-fss/1`` strategy with one memory node, to its file (the module docstring).

    Raises:
        InputError: no property of the report has a strategy to export (only unbounded P and R
            queries have a memoryless one), or a destination cannot be written.
    """
    from posgmc.strategies.files import write_strategy

    results = [r for r in report.outcomes if not isinstance(r, tuple)]
    several = len(report.outcomes) > 1
    shown = point if several_points else {}
    written: list[Written] = []
    synthesised = any(getattr(r, "strategies", ()) for r in results)
    for index, r in enumerate(report.outcomes):
        if isinstance(r, tuple):
            continue  # its error is reported
        where = destination(root, directory=synthesised, index=index, name=r.name,
                            several_properties=several, point=shown)
        if synthesised and r.strategies:
            _make_directory(where)
            players: set[str] = set()
            for fss in r.strategies:
                player = fss.player or "agent"
                path = os.path.join(where, f"{player}.vs_fss.json" if player in players
                                    else f"{player}.json")
                write_strategy(fss, path)
                written.append(Written(path))
                players.add(player)
        elif not synthesised and r.strategy is not None:
            written += _write_memoryless(where, r, report.model, zero_based_players)
    if not written and results:
        raise InputError(f"{OPTION}: no property checked here has a strategy to export",
                         hint="a memoryless strategy comes with unbounded P and R queries "
                         "(F, U, C, ...); a synthesised one with P and R queries of a pomdp/posg")
    return written


def _write_memoryless(where: str, result: Any, model: Any, zero_based: bool) -> list[Written]:
    """A model checker's memoryless strategy as ``posgmc-fss/1`` files, one per coalition player
    (the state-indexed form where the choices cannot be said by observation and label)."""
    from posgmc.strategies.binding import bind, memoryless_strategy
    from posgmc.strategies.files import write_memoryless_strategy, write_strategy
    from posgmc.strategies.fss import StrategyError

    players = coalition_players(result.property, model, zero_based)
    strategies = []
    try:
        for p in players:
            fss = memoryless_strategy(model, p, result.strategy)
            bind(model, fss)  # what check --strategy will do with the file: it must fit
            strategies.append(fss)
    except (StrategyError, InputError) as e:
        write_memoryless_strategy(where, result.property, model, result.strategy)
        reason = e.message.split(": ", 1)[-1] if isinstance(e, StrategyError) else e.message
        return [Written(where, "the state-indexed memoryless strategy of every player, not "
                        f"posgmc-fss/1: {reason}")]
    if len(strategies) == 1:
        write_strategy(strategies[0], where)
        return [Written(where)]
    base, ext = os.path.splitext(where)
    paths = []
    for fss in strategies:
        path = f"{base}.{_part(fss.player)}{ext or '.json'}"
        write_strategy(fss, path)
        paths.append(Written(path))
    return paths


def coalition_players(prop: str, model: Any, zero_based: bool) -> list[int]:
    """The players whose choices a model checker's strategy for ``prop`` is about, in the model's
    order: the coalition of its (first) query (``<<C>>``: C; ``[[C]]``: the players against C,
    who hold C to the value); every player of a game when the query names none; ``[0]``, the
    agent, on an mdp."""
    from posgmc.semantics.queries import QueryResolver
    from posgmc.syntax.ast import CoalitionKind, ProbQuery, RewardQuery
    from posgmc.syntax.parser import parse_property
    from posgmc.syntax.traversal import iter_nodes

    everyone = list(range(len(model.player_names))) or [0]
    if not model.player_names:
        return everyone
    query = next((n for n in iter_nodes(parse_property(prop).expr)
                  if isinstance(n, (ProbQuery, RewardQuery))), None)
    if query is None or query.coalition is None:
        return everyone
    resolver = QueryResolver(model.model_type, tuple(model.player_names),
                             tuple(rm.name for rm in model.reward_models), zero_based)
    members = resolver.coalition_of(query.coalition) or frozenset(everyone)
    if query.coalition.kind is CoalitionKind.BRACKET:
        members = frozenset(everyone) - members
    return sorted(members) or everyone


def _make_directory(path: str) -> None:
    try:
        os.makedirs(path, exist_ok=True)
    except OSError as e:
        raise InputError(f"{OPTION}: cannot create the directory {path}: "
                         f"{e.strerror or e}") from None


def point_of(constants: Mapping[str, Any], swept: Sequence[str]) -> dict[str, str]:
    """The swept constants' values at one point, as text."""
    from posgmc.cli.constants import const_text

    return {n: const_text(constants[n]) for n in swept}
