"""Errors that reach the user as one clear message instead of a traceback.

The CLI prints `str(error)` and exits with `error.exit_code`: 2 for bad input (usage, config,
model, missing plugin), 1 for a failure while running.
"""

from __future__ import annotations


class JoshuaError(Exception):
    """Base of every error JOSHUA reports to the user."""

    exit_code = 1


class UsageError(JoshuaError):
    """The user asked for something that does not exist or cannot be combined."""

    exit_code = 2


class ConfigError(UsageError):
    """A config or preset is malformed or inconsistent; the message says file:line:col."""


class ModelError(UsageError, ValueError):
    """A model file is missing or does not compile."""


class CorruptCheckpointError(UsageError):
    """A checkpoint file is missing, damaged or does not fit what it is loaded into: the input is bad (exit 2)."""


class PluginNotFoundError(UsageError):
    """No installed plugin provides the requested component; the message says what to install."""


class PluginLoadError(JoshuaError):
    """An installed plugin is broken: it failed to import or registered something invalid."""


class TrainingDiverged(JoshuaError):
    """A loss or the policy's parameters became NaN or infinite; training stopped before writing anything from
    that state (a run failure: exit 1, as any trainer's)."""
