"""Helpers shared by test packages (not tests themselves): ``chromium`` (a headless-browser probe)."""
