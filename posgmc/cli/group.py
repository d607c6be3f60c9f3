"""The ``posgmc`` command group; each command family registers itself on it."""

from __future__ import annotations

import click

from posgmc import __version__

__all__ = ["main"]


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, "--version", prog_name="posgmc")
def main() -> None:
    """posgmc: model checking and strategy synthesis for partially observable stochastic games."""
