"""What goes wrong in deployment, as the project's own error types.

`DeployConfigError` is a malformed deploy.yaml (file, line, column, what was
expected); `DeployError` is anything else a person can act on: a host that does
not answer, a refused key, an unknown or changed host key, a command that failed.
Its message is one line, the row of the result table or the command's error line.
"""
from __future__ import annotations

from fleet_common.errors import FleetError, FormatError

__all__ = ["DeployError", "DeployConfigError", "HostKeyRefused"]


class DeployError(FleetError):
    """A deployment step could not be done; the message says why and what to do."""


class DeployConfigError(FormatError):
    """deploy.yaml is malformed or incomplete."""


class HostKeyRefused(DeployError):
    """The host's key is not the one pinned in known_hosts (unknown, or `changed`)."""

    def __init__(self, message: str, changed: bool = False) -> None:
        super().__init__(message)
        self.changed = changed
