"""What the coalition and the reward structure of a query refer to, resolved in one place.

Coalitions: PRISM-games numbers players from 1 (``<<1>>`` = first declared player,
``PropertiesSemanticCheck``: "Valid player references are either integers in the range
1..numPlayers or a name"); Storm and PAYNT number them from 0. Numbers are read 1-based unless the
caller asks for ``zero_based=True`` (``--zero-based-players``). A coalition on a model that is not
a game is an error (PRISM-games silently ignores ``<<*>>`` there; an explicit error is kinder).

Reward structures: by name, by 1-based index, or the first one when none is given.

The semantic stage records the answers in :class:`ResolvedQuery`; the checkers ask the same
:class:`QueryResolver` for the coalition of the queries they derive from those (a threshold
dropped, a direction made explicit), so a reference means the same and fails with the same
message whether the model came from PRISM text or from DRN.
"""

from __future__ import annotations

from dataclasses import dataclass

from posgmc.errors import PosgmcError
from posgmc.model.explicit import ExplicitModel, RewardModel
from posgmc.semantics.symbols import model_type_phrase, report
from posgmc.syntax.ast import (
    Coalition,
    CoalitionKind,
    ModelType,
    PlayerRef,
    ProbQuery,
    RewardQuery,
)

__all__ = ["QueryResolver", "ResolvedQuery", "reward_structure"]


@dataclass(frozen=True)
class ResolvedQuery:
    """What a ``P``/``R`` node of a checked property refers to.

    ``coalition``: 0-based indices into the model's players; None when the query has no
    coalition. ``coalition_kind``: ``<<..>>`` or ``[[..]]`` (None without coalition).
    ``reward_index``: 0-based index into the model's reward structures (``R`` queries only).
    """

    node: ProbQuery | RewardQuery
    coalition: frozenset[int] | None
    coalition_kind: CoalitionKind | None
    reward_index: int | None


@dataclass(frozen=True)
class QueryResolver:
    """Resolves coalitions and reward structures against one model's players (in declaration
    order) and reward structures (``None`` for an unnamed one)."""

    model_type: ModelType
    players: tuple[str, ...]
    reward_names: tuple[str | None, ...]
    zero_based: bool = False

    # -- raising forms, for the checkers ----------------------------------------------------------

    def coalition_of(self, c: Coalition | None) -> frozenset[int] | None:
        """The 0-based player indices of a coalition (None: no coalition written).

        Raises:
            PosgmcError: the first error in the coalition.
        """
        if c is None:
            return None
        errors: list[PosgmcError] = []
        out = self.coalition(c, errors)
        if errors:
            raise errors[0]
        return out

    # -- collecting forms, for the semantic stage --------------------------------------------------

    def resolve(self, q: ProbQuery | RewardQuery, errors: list[PosgmcError]) -> ResolvedQuery:
        """The record of one query; its errors are appended to ``errors``."""
        coalition = None if q.coalition is None else self.coalition(q.coalition, errors)
        reward = self.reward_index(q, errors) if isinstance(q, RewardQuery) else None
        kind = q.coalition.kind if q.coalition is not None else None
        return ResolvedQuery(q, coalition, kind, reward)

    def coalition(self, c: Coalition, errors: list[PosgmcError]) -> frozenset[int] | None:
        """The 0-based player indices of ``c``, or None after appending its errors."""
        players = self.players
        if not self.model_type.is_game:
            report(
                errors,
                "a coalition only applies to games (smg, posg), not to "
                + model_type_phrase(self.model_type),
                c.span,
                hint="remove the coalition operator",
            )
            return None
        if c.all_players:
            return frozenset(range(len(players)))
        out: set[int] = set()
        ok = True
        for ref in c.players:
            index = self._player(ref, errors)
            if index is None:
                ok = False
            elif index in out:
                report(
                    errors,
                    f'player "{players[index]}" appears twice in the coalition',
                    ref.span,
                    hint="name each player once",
                )
                ok = False
            else:
                out.add(index)
        return frozenset(out) if ok else None

    def _player(self, ref: PlayerRef, errors: list[PosgmcError]) -> int | None:
        players = self.players
        n = len(players)
        first = 0 if self.zero_based else 1
        if ref.name is not None:
            if ref.name in players:
                return players.index(ref.name)
            listing = ", ".join(f"{i + first}: {p}" for i, p in enumerate(players))
            report(
                errors,
                f'unknown player "{ref.name}" in coalition',
                ref.span,
                hint=f"the players are {listing}" if players else None,
            )
            return None
        k = ref.number if ref.number is not None else -1
        if first <= k < n + first:
            return k - first
        if not self.zero_based and k == 0:
            message = (
                "player number 0 does not exist: PRISM-games numbers players from 1, while "
                "Storm and PAYNT number them from 0"
            )
            remedy = (
                "write <<1>> for the first player, or read player numbers from 0 as "
                "Storm/PAYNT do with --zero-based-players (zero_based_players=True in Python)"
            )
        else:
            listing = ", ".join(f"{i + first}: {p}" for i, p in enumerate(players))
            message = (
                f"player number {k} does not exist: the model has {n} "
                f"player{'s' if n != 1 else ''} ({listing})"
            )
            remedy = (
                "numbers count from 0 (--zero-based-players)"
                if self.zero_based
                else "numbers count from 1 as in PRISM-games; Storm/PAYNT's 0-based numbers "
                "need --zero-based-players"
            )
        # both numberings, so that a file written for the other tool is recognised as such
        both = ", ".join(
            f'"{p}" = <<{i + 1}>> (<<{i}>> with --zero-based-players)'
            for i, p in enumerate(players)
        )
        hint = f"the players are {both}; {remedy}" if players else remedy
        report(errors, message, ref.span, hint=hint)
        return None

    def reward_index(self, q: RewardQuery, errors: list[PosgmcError]) -> int | None:
        """The 0-based index of the query's reward structure, or None after appending an
        error."""
        names = self.reward_names
        n = len(names)
        if q.reward is None or isinstance(q.reward, int):
            if n == 0:
                report(errors, "the model has no reward structures", q.span)
                return None
            if q.reward is None:
                return 0
            if not 1 <= q.reward <= n:
                report(
                    errors,
                    f"reward structure number {q.reward} does not exist: the model has {n} "
                    f"(numbered from 1)",
                    q.span,
                )
                return None
            return q.reward - 1
        if q.reward in names:
            return list(names).index(q.reward)
        named = ", ".join(f'"{r}"' for r in names if r)
        report(
            errors,
            f'unknown reward structure "{q.reward}"',
            q.span,
            hint=f"the reward structures are {named}"
            if named
            else "the model has no named reward structures",
        )
        return None


def reward_structure(model: ExplicitModel, q: RewardQuery) -> RewardModel:
    """The reward structure ``q`` refers to in ``model``, resolved by :class:`QueryResolver` as
    in the semantic stage (a model derived from the checked one, a product or a lifted game, keeps
    the reward structures in their order and with their names).

    Raises:
        PosgmcError: the reference names none of the model's reward structures (the semantic
            stage has reported that before any engine runs).
    """
    names = tuple(rm.name for rm in model.reward_models)
    resolver = QueryResolver(model.model_type, tuple(model.player_names), names)
    errors: list[PosgmcError] = []
    index = resolver.reward_index(q, errors)
    if index is None:
        raise errors[0]
    return model.reward_models[index]
