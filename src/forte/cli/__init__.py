"""The ``forte`` command line: one module per sub-command, registered by :mod:`forte.cli.main`."""

from forte.cli.main import main

__all__ = ["main"]
