"""Interim: moved here by the dataset app restructure."""

from ..dataset import configure_parser, run  # noqa: F401
