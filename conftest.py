"""Repository-level pytest settings: what ``--doctest-modules`` must not import."""

# running the CLI module would execute a command
collect_ignore = ["spectral_cam/cli/__main__.py"]
