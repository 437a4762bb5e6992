"""The kinds of component a plugin registers: a vocabulary the plugin host, the config policy and the provider
catalog share. A leaf: it imports nothing of JOSHUA, so every layer may use it."""

from __future__ import annotations

import enum


class Kind(enum.Enum):
    """The kinds of component a plugin can register, with the hook that registers each."""

    BACKEND = "backend"
    MODE = "mode"
    TRAINER = "trainer"
    TASK = "task"
    TERM = "term"
    COMMAND = "command"
    OPTIONS = "option"
    READER = "reader"
    TRAJECTORY_READER = "trajectory_reader"
    POLICY_FORMAT = "policy_format"
    DATA = "data_folder"

    @property
    def hook_name(self) -> str:
        return f"joshua_register_{self.value}s"
