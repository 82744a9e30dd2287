"""Errors that the command line reports as one clear line (exit code 2) instead of a traceback."""


class UserError(Exception):
    """A problem with the user's input (missing file, not IFC, bad option): one line, exit code 2."""
