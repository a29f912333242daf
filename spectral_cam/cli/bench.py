"""Interim: moved here by the bench app restructure."""

from ..bench import configure_parser, run  # noqa: F401
