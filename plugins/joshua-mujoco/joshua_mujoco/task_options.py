"""Task options given as keyword arguments (make_vector_env, the Gymnasium entry points) as a TaskConfig."""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

from joshua_core.config_pb2 import TaskConfig


def task_config_from_options(options: Mapping[str, Any]) -> TaskConfig | None:
    """A TaskConfig from keyword options: task_config (a TaskConfig), episode_length, frame_skip, and
    terms={name: {"weight": w, "params": {...}}}."""
    allowed = {"task_config", "episode_length", "frame_skip", "terms"}
    unknown = sorted(set(options) - allowed)
    if unknown:
        raise TypeError(f"unknown task options {unknown}; accepted: {', '.join(sorted(allowed))}")
    if not options:
        return None
    config = TaskConfig()
    if options.get("task_config") is not None:
        config.CopyFrom(options["task_config"])
    config.episode_length = options.get("episode_length") or config.episode_length
    config.frame_skip = options.get("frame_skip") or config.frame_skip
    for name, change in (options.get("terms") or {}).items():
        override = config.terms.add(name=name)
        if "weight" in change:
            override.weight = float(change["weight"])
        for key, value in (change.get("params") or {}).items():
            override.params[key] = json.dumps(list(value) if isinstance(value, tuple) else value)
    return config
