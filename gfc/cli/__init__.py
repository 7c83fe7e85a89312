"""The ``gfc`` command. Each command family lives in its own module and registers here."""

from gfc.cli.app import app, main

__all__ = ["app", "main"]
