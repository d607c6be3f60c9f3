"""``python -m posgmc``: the command-line interface, as the ``posgmc`` script runs it."""

from posgmc.cli import main

main()
