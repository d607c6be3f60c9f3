"""Running a command: its work inside the deep-stack runner, errors rendered with their position
(and as JSON for machines), interrupts and broken pipes, and the exit status."""

from __future__ import annotations

import json
import sys
import traceback
from collections.abc import Callable, Sequence
from typing import Any, NoReturn

import click

from posgmc.cli.options import EXIT_ERROR, EXIT_INTERRUPTED, EXIT_OK
from posgmc.errors import MultipleErrors, PosgmcError

__all__ = ["fail", "error_json", "internal_error_json", "guard"]


def fail(error: PosgmcError | Exception, *, debug: bool) -> NoReturn:
    if isinstance(error, PosgmcError):
        click.echo(error.render(), err=True)
    else:
        click.echo(f"internal error: {type(error).__name__}: {error}", err=True)
        click.echo(
            "  hint: this is a bug in posgmc; rerun with --debug for the traceback", err=True
        )
    if debug:
        traceback.print_exception(error, file=sys.stderr)
    sys.exit(EXIT_ERROR)


def show_const_text(error: PosgmcError, consts: Sequence[str]) -> None:
    """Errors that point into a --const option get its text to show under the caret."""
    from posgmc.errors import SourceText

    names = ["--const"] if len(consts) == 1 else [f"--const #{i + 1}" for i in range(len(consts))]
    sources = {n: SourceText(t, n) for n, t in zip(names, consts)}
    for e in error.errors if isinstance(error, MultipleErrors) else [error]:
        if e.span is not None and e.span.file in sources and e.source is None:
            e.with_source(sources[e.span.file])


def error_json(error: PosgmcError) -> list[dict[str, Any]]:
    """The machine-readable form of an input error: one object per error, with its position: the
    file, line and column of a source text, or the file and JSON path (``json_path``, e.g.
    ``rules[3].action``) of a strategy file."""
    errors = error.errors if isinstance(error, MultipleErrors) else [error]
    out = []
    for e in errors:
        span = e.span
        out.append({
            "file": span.file if span else getattr(e, "file", None),
            "line": span.line if span else None,
            "column": span.column if span else None,
            "json_path": getattr(e, "path", None),
            "message": e.message,
            "hint": e.hint,
        })
    return out


def internal_error_json(error: BaseException) -> dict[str, Any]:
    """An internal error in the shape of :func:`error_json`, so that a machine reading ``--json``
    gets a JSON answer on stdout for every failure."""
    return {"errors": [{"file": None, "line": None, "column": None, "json_path": None,
                        "message": f"internal error: {type(error).__name__}: {error}",
                        "hint": "this is a bug in posgmc; rerun with --debug for the traceback"}]}


def guard(
    debug: bool, fn: Callable[[], int], *, as_json: bool = False, consts: Sequence[str] = ()
) -> NoReturn:
    from posgmc.deep_stack import deep_call

    try:
        code = deep_call(fn)
    except PosgmcError as e:
        show_const_text(e, consts)
        if as_json:  # machines get the errors on stdout too, in the shape of docs/cli.md
            click.echo(json.dumps({"errors": error_json(e)}))
        fail(e, debug=debug)
    except (click.exceptions.Exit, click.ClickException):
        raise
    except KeyboardInterrupt:
        click.echo("interrupted", err=True)
        sys.exit(EXIT_INTERRUPTED)
    except BrokenPipeError:  # output piped into e.g. `head`: stop quietly, as Unix tools do
        sys.stderr.close()
        sys.exit(EXIT_OK)
    except Exception as e:  # noqa: BLE001 - the CLI never shows a bare traceback
        if as_json:
            click.echo(json.dumps(internal_error_json(e)))
        fail(e, debug=debug)
    sys.exit(code)


# -- constants: PRISM's --const N=4,p=0.9 and sweeps N=1:1:5 -----------------------------------
