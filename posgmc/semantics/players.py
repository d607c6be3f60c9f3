"""Players of a game: which modules and actions each ``player ... endplayer`` block owns.

PRISM-games' rules (``ModulesFile.checkPlayerDefns``): games (``smg``, and posgmc's ``posg``) must
declare players and other model types must not; player names are distinct; every module and action
named in a player block exists; no module and no action is owned by two players. Whether every
choice of the built game has an owner is a question for exploration (``compiler/``), not here: an
unowned action that is never enabled is harmless.
"""

from __future__ import annotations

from dataclasses import dataclass

from posgmc.errors import PosgmcError, SourceSpan
from posgmc.semantics.resolve import ResolvedModel, position
from posgmc.semantics.symbols import line_of, model_type_phrase, report
from posgmc.syntax.ast import PlayerDecl

__all__ = ["PlayerInfo", "check_players"]


@dataclass(frozen=True)
class PlayerInfo:
    """A checked player: its modules and actions (unknown and doubly owned ones dropped)."""

    name: str
    modules: tuple[str, ...]
    actions: tuple[str, ...]
    decl: PlayerDecl
    span: SourceSpan


def check_players(resolved: ResolvedModel, errors: list[PosgmcError]) -> tuple[PlayerInfo, ...]:
    """Check the player blocks of a model.

    Args:
        resolved: the resolved model.
        errors: where errors are appended.

    Returns:
        The players in declaration order (empty for non-games).
    """
    model = resolved.model
    mtype = model.model_type
    players = resolved.players
    if not mtype.is_game:
        if players:
            report(
                errors,
                "player blocks are only allowed in games (smg, posg), not in "
                + model_type_phrase(mtype),
                players[0].span,
                hint="declare the model as smg (or posg), or remove the player blocks",
            )
        return ()
    if not players:
        span = model.span if model.span.line else SourceSpan(1, 1)
        report(
            errors,
            f"a game ({mtype.value}) must declare its players",
            span,
            hint='add e.g. "player p1 module1, [action1] endplayer" for each player',
        )
        return ()

    module_names = {m.name for m in resolved.modules}
    actions = set(resolved.actions)
    seen_players: dict[str, PlayerDecl] = {}
    module_owner: dict[str, tuple[str, SourceSpan]] = {}
    action_owner: dict[str, tuple[str, SourceSpan]] = {}
    out: list[PlayerInfo] = []
    for p in sorted(players, key=lambda p: position(p.span)):
        if p.name in seen_players:
            report(
                errors,
                f'player "{p.name}" is already defined{line_of(seen_players[p.name].span)}',
                p.span,
            )
        else:
            seen_players[p.name] = p
        mods: list[str] = []
        for ref in p.modules:
            if ref.name not in module_names:
                hint = None
                if ref.name in actions:
                    hint = f'"{ref.name}" is an action; write it in brackets: [{ref.name}]'
                report(errors, f'unknown module "{ref.name}" in player "{p.name}"', ref.span, hint)
            elif ref.name in module_owner:
                owner, where = module_owner[ref.name]
                report(
                    errors,
                    f'module "{ref.name}" is already owned by player "{owner}"{line_of(where)}',
                    ref.span,
                    hint="a module's unlabelled commands belong to exactly one player",
                )
            else:
                module_owner[ref.name] = (p.name, ref.span)
                mods.append(ref.name)
        acts: list[str] = []
        for a in p.actions:
            if a.name not in actions:
                hint = None
                if a.name in module_names:
                    hint = f'"{a.name}" is a module; write it without brackets'
                report(errors, f'unknown action "{a.name}" in player "{p.name}"', a.span, hint)
            elif a.name in action_owner:
                owner, where = action_owner[a.name]
                report(
                    errors,
                    f'action "{a.name}" is already owned by player "{owner}"{line_of(where)}',
                    a.span,
                    hint="each action belongs to exactly one player",
                )
            else:
                action_owner[a.name] = (p.name, a.span)
                acts.append(a.name)
        out.append(PlayerInfo(p.name, tuple(mods), tuple(acts), p, p.span))
    # declaration order = source order; keep the first block of a doubly defined name only
    first: dict[str, PlayerInfo] = {}
    for info in out:
        first.setdefault(info.name, info)
    return tuple(first.values())
