"""Errors that the command line reports as one clear line (exit code 2) instead of a traceback.

Anything else that escapes a command is a bug: :func:`bimbot.cli.main` logs its traceback (the service's
log under ``bimbot run``) and exits 1.
"""


class UserError(Exception):
    """A problem with the user's input (missing file, not IFC, bad option): one line, exit code 2."""


class InputError(UserError, ValueError):
    """Bad user input that only shows once a service runs (a URDF without wheel joints, a robot id physics
    did not spawn, a build whose meshes are missing): one line and exit 2 from the command, and still a
    ``ValueError`` for library callers and tests that catch that."""
