"""The ``vecpin`` command: argument parsing and printing only, over the workflows.

Each module of this package adds its subcommands with ``add_commands(sub)``; a new command
is a new module listed in :data:`vecpin.cli.main.COMMAND_MODULES`.
"""
from vecpin.cli.main import build_parser, main

__all__ = ["build_parser", "main"]
