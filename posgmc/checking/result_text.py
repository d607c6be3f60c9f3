"""Results as a person reads them: the lines ``posgmc check`` prints for one property.

A result reads headline first: the property, its value (the shortest decimal inside its proven
interval, :mod:`posgmc.checking.decimals`) and that interval. A result about finite-state
strategies (given with ``--strategy`` or synthesised) names each further number by its role for
the decision maker's direction, so that it reads right for min and max alike: for a maximiser the
bound on what any defence achieves is an upper one ("no defence above"), for a minimiser a lower
one ("no defence below"); the JSON keys (``guaranteed``, ``vs_fss_adversary``, ``upper_bound``,
``full_observation``) stay as documented and are shown beside each role.

A synthesised result is short by default: the headline with ``guaranteed``'s proven interval, the
bracket on the optimum when one was computed (``optimum``), and one line of how the defence was
found. ``verbose`` adds each number with its meaning, the phases' times and the adversary phases.
A note (what a number means) is shown once per run, however many properties share it: pass the
same ``seen`` set to every call.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from posgmc.checking.decimals import plain, shortest_in
from posgmc.checking.results import PropertyResult

__all__ = ["number_text", "point_text", "result_lines", "role_of",
           "value_text"]


def number_text(value: float | bool | None, lower: float | None = None,
                upper: float | None = None) -> str:
    """A value as printed: ``true``/``false``, ``unknown`` for an undecided Boolean, else the
    shortest decimal inside ``[lower, upper]`` (:func:`~posgmc.checking.decimals.shortest_in`)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if value is None:
        return "unknown"
    if value != value:
        return "NaN"
    return shortest_in(float(value), lower, upper)


def _interval(lower: float | None, upper: float | None) -> str:
    if lower is None or upper is None:
        return ""
    return f"  [{plain(lower)}, {plain(upper)}]"


def _open(lower: float | None, upper: float | None) -> bool:
    """Whether ``[lower, upper]`` is a proper interval (finite, wider than a point)."""
    return lower is not None and upper is not None and math.isfinite(lower) \
        and math.isfinite(upper) and lower < upper


def point_text(value: float | bool | None, lower: float | None, upper: float | None, *,
               settled: bool) -> str:
    """The one text that stands for a value: the shortest decimal inside its proven interval
    (:func:`number_text`) when the check ``settled`` (converged to the precision asked, and
    proved it), else the interval itself when it is wider than a point: the point inside an
    unsettled interval is a midpoint nothing computed, and its shortest decimal can sit at an end
    of a wide interval (``1`` for ``[0.487, 1]``), which reads as an answer."""
    if not settled and not isinstance(value, bool) and _open(lower, upper):
        return f"[{plain(lower)}, {plain(upper)}]"  # type: ignore[arg-type]
    return number_text(value, lower, upper)


def value_text(value: float | bool | None, lower: float | None, upper: float | None, *,
               settled: bool) -> str:
    """A value followed by its proven interval, as a result line shows it (an unsettled one as
    the interval alone, :func:`point_text`; a Boolean without one)."""
    if isinstance(value, bool) or (not settled and _open(lower, upper)):
        return point_text(value, lower, upper, settled=settled)
    return number_text(value, lower, upper) + _interval(lower, upper)


def role_of(key: str, *, maximizing: bool, synthesised: bool = True) -> str:
    """The text name of one of the strategy numbers, by its role for a maximising (Pmax, Rmax)
    or minimising (Pmin, Rmin) decision maker; ``synthesised``: the adversaries are those the
    synthesis found, not a given strategy."""
    beyond = "above" if maximizing else "below"
    return {
        "guaranteed": "guaranteed",
        "vs_fss_adversary": "against the adversaries found" if synthesised
        else "against the given adversary",
        "upper_bound": f"no defence {beyond}",
        "full_observation": f"no defence {beyond}, full observation",
    }[key]


_MEANING = {
    "guaranteed": "{who}'s strategy ensures {best} this against every adversary, even one that "
                  "sees everything",
    "vs_fss_adversary": "its worst value against the adversary's {adversaries}",
    "upper_bound": "no strategy of {who} does better against the strongest of them",
    "full_observation": "no strategy of {who} does better, not even one that sees everything",
}


def _meaning(key: str, r: PropertyResult, maximizing: bool) -> str:
    """What a synthesised result's number means, in words."""
    stats: Mapping[str, Any] = r.synthesis or {}
    memory = stats.get("adversary_memory", 1)
    kind = "memoryless" if memory == 1 else f"{memory}-node finite-state"
    counted = stats.get("vs_adversaries", 0)
    adversaries = (f"deterministic {kind} strategies"
                   + (f" (all {counted})" if stats.get("exhaustive") else
                      f" (the {counted} strongest found)"))
    who = (r.memory[0][0] or "the agent") if r.memory else "the decision maker"
    return _MEANING[key].format(who=who, best="at least" if maximizing else "at most",
                                adversaries=adversaries)


def _headline(r: PropertyResult) -> str:
    """``property: value  [lower, upper]  (method, ...)`` with the marks of an unproven answer."""
    from posgmc.semantics.evaluate import format_value

    if r.exact is not None:
        value = format_value(r.exact) + _interval(r.lower, r.upper)
    else:
        value = value_text(r.value, r.lower, r.upper, settled=r.converged and r.sound)
    line = f"{r.property}: {value}"
    if r.synthesis is not None:  # how it was proven is on the "how" line
        line += f"  (synthesis, {r.seconds:.3f} s)"
    else:
        line += f"  ({r.method}, {r.iterations} it., {r.seconds:.3f} s)"
    if r.value is None:
        line += "  (the proven bounds do not decide it, even after refining)"
    if not r.converged:
        line += ("  NOT CONVERGED: the bounds hold but are wider than the precision (iteration"
                 " cap, or rounding of the model's numbers along very long expected paths)")
    if not r.sound:
        line += "  NOT PROVEN: bounds did not separate or the method is unsound"
    return line


def _number_line(key: str, r: PropertyResult, *, verbose: bool) -> str | None:
    number = getattr(r, key, None)
    if number is None:
        return None
    maximizing = True if r.maximizing is None else r.maximizing
    role = role_of(key, maximizing=maximizing, synthesised=r.synthesis is not None)
    settled = number.sound and number.converged
    line = f"  {role}: {value_text(number.value, number.lower, number.upper, settled=settled)}"
    if role != key:
        line += f"  ({key})"
    if not number.sound:
        line += "  NOT PROVEN: its check did not converge to proven bounds"
    if verbose and r.synthesis is not None:
        line += f"  {_meaning(key, r, maximizing)}"
    return line


def _how_found(r: PropertyResult, stats: Mapping[str, Any]) -> str:
    """One line: which strategy, from which phase, proven how, and whether the budget ran out."""
    strategies = r.strategies
    defence = strategies[0] if strategies else None
    who = (r.memory[0][0] or "the agent") if r.memory else "the decision maker"
    if defence is not None:
        nodes = defence.memory_size
        kind = "deterministic" if defence.is_deterministic else "randomised"
        what = f"{who}'s {kind} strategy with {nodes} memory node{'s' if nodes != 1 else ''}"
    else:
        what = f"{who}'s strategy"
    composed = stats.get("defence") == "composed"
    source = (f"composed against the {stats.get('adversaries_kept', 0)} strongest adversary "
              "strategies" if composed else
              "a belief-based controller built to close the optimum bracket (--gap)"
              if stats.get("defence") == "belief" else "found by the search")
    proven = r.method.removeprefix("synthesis (").removesuffix(")")
    line = f"  how: {what}, {source}, proven by {proven} iteration" if proven == "interval" else \
        f"  how: {what}, {source}, proven by {proven}"
    sharpened = stats.get("sharpened")
    if sharpened:
        line += f"; {sharpened}"
    cut = stats.get("cut")
    if cut == "timeout":
        line += ("; PARTIAL: --timeout cut the work budget (the numbers, still proven, may depend "
                 "on the machine)")
    elif cut == "interrupt":
        line += "; INTERRUPTED: the best defence verified so far"
    elif stats.get("partial"):
        line += "; PARTIAL: a sound check did not converge"
    return line


def _synthesis_detail(stats: Mapping[str, Any]) -> list[str]:
    """The search rounds, the phases' times and the adversary phases (``-v``)."""
    lines = []
    rounds = ", ".join(
        f"k={x['memory']}: {plain(x['value_policy_iteration'])}" for x in stats.get("rounds", ())
    )
    if rounds:
        lines.append(f"  rounds: {rounds} (best defence so far per memory size, by policy "
                     "iteration)")
    phases = ", ".join(f"{k} {v:.2f} s" for k, v in stats.get("phases", {}).items())
    cap = "" if stats.get("timeout") is None else f", --timeout {stats['timeout']:g} s"
    budget = f"effort {stats.get('effort', 1.0):g}{cap}, seed {stats['seed']}" if "seed" in stats \
        else ""
    lines.append("  phases: " + "; ".join(p for p in (phases, budget) if p))
    if "adversaries_enumerated" in stats:
        added = stats["adversaries_added"]
        lines.append(
            f"  adversaries: {stats['adversaries_enumerated']} strategies enumerated"
            + (" (all of them)" if stats["exhaustive"] else "")
            + f", {stats['adversaries_ranked']} ranked by strength, the defence composed against"
            f" the {stats['adversaries_kept']} strongest"
            + (f" ({added} added by the double oracle)" if added else "")
            + ("; the composed defence is reported" if stats["defence"] == "composed" else
               "; a belief-based controller is reported (--gap), not checked against them"
               if stats["defence"] == "belief" else
               "; the search's defence is reported (the composed one proves no more)")
            + ("" if stats["defence"] == "belief" else
               f"; 'against the adversaries found' is the composed defence's, over "
               f"{stats['vs_adversaries']}" if stats["vs_fss_defence"] != stats["defence"] else
               f"; 'against the adversaries found' is over {stats['vs_adversaries']}"))
    return lines


def result_lines(r: PropertyResult | tuple[str, Any], *, verbose: bool = False,
                 seen: set[str] | None = None) -> list[str]:
    """The lines of one property's result (or of its error, as ``(property, error)``: the
    error's own text goes to stderr, the caller prints it).

    Args:
        verbose: also each number's meaning and the synthesis' statistics.
        seen: notes already shown in this run; a note in it is not repeated, and a shown one is
            added.
    """
    if isinstance(r, tuple):
        return [f"{r[0]}: ERROR"]
    lines = [_headline(r)]
    stats = r.synthesis
    keys = ("guaranteed", "vs_fss_adversary", "upper_bound", "full_observation")
    if stats is not None:
        # the headline is guaranteed's value; it has a line of its own only for a threshold
        shown: tuple[str, ...] = ("guaranteed",) if isinstance(r.value, bool) or r.value is None \
            else ()
        if verbose:
            shown = keys
        lines += [x for k in shown if (x := _number_line(k, r, verbose=verbose)) is not None]
        optimum = getattr(r, "optimum", None)
        if optimum is not None:  # the bracket on the best value any defence achieves
            method = getattr(optimum, "method", None)
            lines.append(f"  optimum: [{plain(optimum.lower)}, {plain(optimum.upper)}]"
                         + (f"  ({method})" if method else ""))
        lines.append(_how_found(r, stats))
        if verbose:
            lines += _synthesis_detail(stats)
            if r.memory:
                lines.append("  memory: " + ", ".join(f"{p or 'agent'}={k}" for p, k in r.memory))
    else:
        lines += [x for k in keys if (x := _number_line(k, r, verbose=verbose)) is not None]
        if r.memory:
            lines.append("  memory: " + ", ".join(f"{p or 'agent'}={k}" for p, k in r.memory))
    note = r.note
    if stats is not None:
        # the synthesis note explains the numbers the verbose lines explain one by one
        note = None if verbose else _synthesis_note(r)
    if note and (seen is None or note not in seen):
        lines.append(f"  note: {note}")
        if seen is not None:
            seen.add(note)
    return lines


def _synthesis_note(r: PropertyResult) -> str | None:
    """What a synthesised result's headline is, once per run; the notes a synthesis adds about
    its setting (e.g. a product with the formula's automaton) stay with each result."""
    extra = [part.strip() for part in (r.note or "").split(";")
             if part.strip().startswith("synthesised on the product")]
    base = ("the value is 'guaranteed': what the synthesised strategy ensures against every "
            "adversary, with its proven interval; -v or --json show the other numbers")
    return "; ".join([base, *extra])
