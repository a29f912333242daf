"""Interim: moved here by the validate app restructure."""

from ..validate import configure_parser, run  # noqa: F401
