"""The error type users see: a message that names the problem and a hint that names the fix."""

from __future__ import annotations


class T2MError(Exception):
    """A user-facing error. The CLI prints ``message`` and ``hint`` without a traceback.

    Args:
        message: what is wrong, naming the offending value or file.
        hint: how to fix it (a command to run, the valid choices...).
    """

    def __init__(self, message: str, hint: str | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.hint = hint

    def __str__(self) -> str:
        return self.message if not self.hint else f"{self.message}\nHint: {self.hint}"


class ConfigError(T2MError):
    """A configuration file, flag or override is invalid."""


class PluginError(T2MError):
    """A plugin is unknown, duplicated, or failed to load."""


class ModelFileError(T2MError):
    """A model file or checkpoint is missing, corrupt or does not match its expected hash."""
