"""The ``posgmc`` command: options become typed configuration, the work happens in
:mod:`posgmc.api`, results are rendered here.

The package reads as the command line: :mod:`~posgmc.cli.group` holds the command group,
:mod:`~posgmc.cli.options` the options several commands share (each declared once) and the exit
codes, :mod:`~posgmc.cli.running` how a command runs and fails, and one module per command family
registers its commands on the group: model (``lint``, ``build``), ``check``, strategies (``test``,
``simulate``, ``show-strategy``) and trade-offs (``pareto``).
"""

from posgmc.cli import check_command, model_commands, strategy_commands, tradeoff_commands
from posgmc.cli.constants import expand_constants
from posgmc.cli.group import main
from posgmc.cli.options import EXIT_ERROR, EXIT_INTERRUPTED, EXIT_OK, EXIT_PROPERTY_FALSE

__all__ = ["main", "expand_constants", "EXIT_OK", "EXIT_PROPERTY_FALSE", "EXIT_ERROR",
           "EXIT_INTERRUPTED"]

# the command modules register themselves on ``main`` when imported
del check_command, model_commands, strategy_commands, tradeoff_commands
