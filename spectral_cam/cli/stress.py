"""Interim: moved here by the stress app restructure."""

from ..stress import configure_parser, run  # noqa: F401
