"""The options several commands share, each declared once, the parsing of their values into typed
configuration, and the exit codes.

Exit status (fixed, documented in docs/cli.md):

* 0 — success; for ``check``, every threshold property holds at the initial state(s);
* 1 — ``check``: some threshold property does not hold or is undecided (``unknown``), a result
  did not converge, or a printed number is not proven (``pareto``: a point's number is not
  proven);
* 2 — bad input (model, properties, constants, options) or any other error;
* 130 — interrupted (Ctrl-C), as shells report it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Literal, TypeVar

import click

__all__ = [
    "EXIT_OK", "EXIT_PROPERTY_FALSE", "EXIT_ERROR", "EXIT_INTERRUPTED",
    "common", "strict_option", "select_option", "selected", "zero_based_players_option",
    "full_observation_option", "memory_option", "timeout_option", "effort_option",
    "progress_options", "seed_option", "executor_options", "gap_option", "positive_finite",
    "finite", "nonnegative_finite",
    "memory_sizes", "synthesis_options", "strategy_options", "placement_of", "capped_jobs",
]

EXIT_OK = 0
EXIT_PROPERTY_FALSE = 1
EXIT_ERROR = 2
EXIT_INTERRUPTED = 130

F = TypeVar("F", bound=Callable[..., Any])


def positive_finite(value: float, option: str) -> float:
    """A precision must be a positive finite number (nan and inf would never stop iterating)."""
    import math

    if not (math.isfinite(value) and value > 0):
        raise click.BadParameter(f"{value!r} is not a positive finite number", param_hint=option)
    return value


def finite(value: float, option: str) -> float:
    """A finite number (nan compares false with everything, so it would pass every range)."""
    import math

    if not math.isfinite(value):
        raise click.BadParameter(f"{value!r} is not a finite number", param_hint=option)
    return value


def nonnegative_finite(value: float, option: str) -> float:
    """A finite number >= 0 (a tolerance)."""
    if not finite(value, option) >= 0:
        raise click.BadParameter(f"{value!r} is negative", param_hint=option)
    return value


# -- shared options --------------------------------------------------------------------------------


def common(f: F) -> F:
    f = click.option("--debug", is_flag=True, help="Show Python tracebacks for errors.")(f)
    f = click.option(
        "--const",
        "consts",
        multiple=True,
        metavar="N=4,p=0.9",
        help="Values for undefined constants (PRISM syntax); ranges N=1:5 or N=1:1:5 sweep.",
    )(f)
    return f


def strict_option(f: F) -> F:
    return click.option(
        "--strict",
        is_flag=True,
        help="PRISM's reading where Storm accepts more (an int variable given int/int, an "
        "observable named like a label): errors instead of warnings.",
    )(f)


def select_option(f: F) -> F:
    return click.option(
        "--select",
        "select",
        multiple=True,
        metavar="NAME|INDEX[,...]",
        help="Only these properties of the properties files: by name (\"name\": P=? [...]) or "
        "1-based position (PRISM's -prop, Storm's --propertyfilter); repeatable.",
    )(f)


def selected(values: Sequence[str]) -> list[str] | None:
    """``--select a,2 --select b`` as ``["a", "2", "b"]``; None when not given."""
    if not values:
        return None
    out = [part.strip() for v in values for part in v.split(",")]
    if any(not part for part in out):
        raise click.BadParameter("an empty property name or position", param_hint="'--select'")
    return out


def zero_based_players_option(f: F) -> F:
    return click.option(
        "--zero-based-players", is_flag=True, help="Numeric coalitions count from 0 (Storm/PAYNT)."
    )(f)


def full_observation_option(f: F) -> F:
    return click.option(
        "--full-observation",
        is_flag=True,
        help="pomdp/posg: answer the value when every player sees the whole state (a bound on the "
        "partially observable value).",
    )(f)


def memory_option(f: F) -> F:
    return click.option(
        "--memory", "memory", multiple=True, metavar="[PLAYER=]K|K1..K2|auto",
        help="Synthesis: memory sizes of the decision maker's strategy (default auto: 1..3, "
        "and for a pomdp a belief-based controller with as many nodes as it needs; "
        "sizes above 1 alone, e.g. 2, are warm-started from a memoryless defence); "
        "PLAYER=... for a named player, e.g. --memory rover=2 --memory attacker=1 (the "
        "adversary's strategies enumerated with that memory). Repeatable.",
    )(f)


def timeout_option(f: F) -> F:
    return click.option(
        "--timeout",
        type=float,
        callback=lambda _c, _p, v: None if v is None else positive_finite(v, "--timeout"),
        default=None,
        help="Synthesis: a wall-clock cap in seconds per property (per point of a sweep or "
        "front), the first counted from the start (loading included); default none. When it "
        "binds, the best defence so far is verified and the result says the timeout cut the "
        "work budget (the numbers may then depend on the machine). For check, it also stops a "
        "model build that outlasts it (after at least one second).",
    )(f)


def effort_option(f: F) -> F:
    return click.option(
        "--effort",
        type=float,
        default=1.0,
        show_default=True,
        callback=lambda ctx, param, value: positive_finite(value, "'--effort'"),
        help="Synthesis: multiply every phase's work budget (gradient steps, random starts, "
        "families, adversaries enumerated, ...: docs/synthesis.md) by this. The numbers depend "
        "only on the model, the properties, the options and --seed.",
    )(f)


def progress_options(f: F) -> F:
    f = click.option(
        "--quiet", "-q", is_flag=True,
        help="Synthesis: no progress on stderr.")(f)
    f = click.option(
        "--progress", "progress_lines", is_flag=True,
        help="Synthesis: progress as lines on stderr (at least one every 2 s, naming the phase "
        "and the best value so far) also when stderr is not a terminal; on a terminal a live "
        "status line is shown anyway.")(f)
    return f


def seed_option(f: F) -> F:
    return click.option(
        "--seed", type=click.IntRange(min=0), default=0, show_default=True,
        help="Synthesis: random seed (a non-negative integer)."
    )(f)


def executor_options(f: F) -> F:
    """``--jobs``, ``--executor`` and ``--ray-address``: where independent evaluations run."""
    f = click.option(
        "--ray-address", default=None, metavar="HOST:PORT",
        help="With --executor ray: the cluster's head (`ray start --head`); default: Ray's "
        "RAY_ADDRESS, else a Ray started on this machine for the run.",
    )(f)
    f = click.option(
        "--executor", type=click.Choice(["local", "ray"]), default="local", show_default=True,
        help="Where --jobs run: local processes, or actors on a Ray cluster (pip install "
        "'posgmc[ray]'; --jobs 1: one actor per CPU of the cluster). Same results.",
    )(f)
    f = click.option(
        "--jobs", type=click.IntRange(min=1), default=1, show_default=True,
        help="Workers for independent work: synthesis's evaluations, or the points of a sweep "
        "or front, or the runs of posgmc test (results and output do not depend on it).",
    )(f)
    return f
def _gap(_ctx: Any, _param: Any, value: str | None) -> Any:
    if value is None:
        return None
    from posgmc.errors import InputError
    from posgmc.synthesis.options import Gap

    try:
        return Gap.parse(value)
    except InputError as e:
        raise click.BadParameter(str(e), param_hint="'--gap'") from None


def gap_option(f: F) -> F:
    return click.option(
        "--gap", "gap", metavar="EPS|EPS%", default=None, callback=_gap,
        help="Synthesis: refine the optimum bracket (the proven bounds on what any defence "
        "achieves) until upper - lower <= EPS (absolute, or EPS% of the larger side) or the "
        "budget ends; the bound side then gets a share of --timeout. Without it the bound side "
        "gets a little time on top of the search.",
    )(f)


def memory_sizes(text: str, given: str) -> tuple[int, ...]:
    from posgmc.synthesis.options import MAX_MEMORY

    try:
        if text == "auto":
            return (1, 2, 3)
        lo, hi = (int(t) for t in text.split("..", 1)) if ".." in text else (int(text),) * 2
    except ValueError:
        raise click.BadParameter(f"{given!r}: give K, K1..K2 or auto, optionally after PLAYER=",
                                 param_hint="'--memory'") from None
    if lo < 1:
        raise click.BadParameter(f"{given!r}: memory sizes start at 1", param_hint="'--memory'")
    if lo > hi:
        raise click.BadParameter(f"{given!r}: a range K1..K2 goes up (K1 <= K2), e.g. {hi}..{lo}",
                                 param_hint="'--memory'")
    if hi > MAX_MEMORY:
        raise click.BadParameter(f"{given!r}: memory sizes go up to {MAX_MEMORY} (a strategy with "
                                 "k nodes has k^2 memory updates per observation and action)",
                                 param_hint="'--memory'")
    return tuple(range(lo, hi + 1))


def synthesis_options(memory: Sequence[str] | str, timeout: float | None, seed: int,
                       adversaries: int = 10, jobs: int = 1, started: float | None = None,
                       effort: float = 1.0, executor: Literal["local", "ray"] = "local",
                       ray_address: str | None = None, gap: Any = None) -> Any:
    """``--memory`` settings as memory sizes: ``2``, ``1..3``, ``auto`` (1..3) for the property's
    coalition, or ``PLAYER=...`` for a named player (the decision maker or the adversary);
    ``started``: where the first property's budget starts (``SynthesisOptions.started``);
    ``executor``/``ray_address``: :func:`executor_options`; ``gap``: the ``--gap`` (a
    :class:`~posgmc.synthesis.options.Gap`) or None."""
    from posgmc.synthesis.options import SynthesisOptions

    if ray_address is not None and executor != "ray":
        raise click.BadParameter("is for --executor ray", param_hint="'--ray-address'")

    settings = [memory] if isinstance(memory, str) else list(memory)
    unnamed: tuple[int, ...] = (1, 2, 3)
    named: dict[str, tuple[int, ...]] = {}
    for given in settings:
        if "=" in given:
            player, text = given.split("=", 1)
            if player.strip() in named:
                raise click.BadParameter(f"{given!r}: player {player.strip()!r} given twice",
                                         param_hint="'--memory'")
            named[player.strip()] = memory_sizes(text.strip(), given)
        else:
            unnamed = memory_sizes(given.strip(), given)
    # memory auto (the default) lets a pomdp's synthesis add a belief-based controller with more
    # nodes; sizes given explicitly bound the strategy's memory
    explicit = any(given.split("=", 1)[-1].strip() != "auto" for given in settings)
    return SynthesisOptions(memory=unnamed, timeout=timeout, seed=seed, adversaries=adversaries,
                            jobs=jobs, executor=executor, ray_address=ray_address,
                            player_memory=tuple(sorted(named.items())),
                            belief=False if explicit else None, started=started, effort=effort,
                            gap=gap)


def placement_of(jobs: int, executor: str, ray_address: str | None) -> Any:
    """:func:`executor_options`' values as a :class:`~posgmc.synthesis.tasks.Placement`: a local
    ``--jobs`` capped at the usable processors (said on stderr), a Ray cluster's left as given
    (the cluster has its own CPUs).

    Raises:
        click.BadParameter: ``--ray-address`` without ``--executor ray``.
    """
    from posgmc.synthesis.tasks import Placement

    if ray_address is not None and executor != "ray":
        raise click.BadParameter("is for --executor ray", param_hint="'--ray-address'")
    if executor == "ray":
        return Placement("ray", jobs, ray_address)
    return Placement("local", capped_jobs(jobs))


def capped_jobs(jobs: int) -> int:
    """``--jobs`` capped at the processors posgmc may use, saying so on stderr when it is."""
    from posgmc.resources import usable_cpus

    usable = usable_cpus()
    if jobs > usable:
        click.echo(f"warning: --jobs {jobs} capped at {usable}: the processors available to "
                   "posgmc (more workers only compete for them)", err=True)
        return usable
    return jobs


def strategy_options(values: Sequence[str]) -> dict[str | None, str]:
    """``("rover=r.json", "a.json")`` -> {"rover": "r.json", None: "a.json"} (None: the file's
    own player).

    Raises:
        click.UsageError: a player given twice, or an empty file name.
    """
    out: dict[str | None, str] = {}
    for text in values:
        player, sep, path = text.partition("=")
        key: str | None = player if sep else None
        path = path if sep else player
        if not path:
            raise click.UsageError(f"--strategy {text!r}: give PLAYER=FILE")
        if key in out:
            raise click.UsageError(
                f"--strategy: two strategies for player {key or '(from file)'!r}"
            )
        out[key] = path
    return out
