"""What `training.deterministic` (`--deterministic`) sets so that a run repeats exactly; docs/determinism.md says
what that covers (exact on the CPU; on the GPU as far as XLA and MuJoCo Warp allow).

XLA reads XLA_FLAGS when JAX starts its backends (its first computation or device query), not when JAX is
imported: `use_determinism` must run before that. The `joshua` command calls it before it imports the trainer,
and the trainers call it first in `train`, for runs started from Python. What only one framework has is set by
the plugin that uses it: `sb3` turns on `torch.use_deterministic_algorithms`; `mjx` warns that MuJoCo Warp on a
GPU does not repeat.
"""

from __future__ import annotations

import os
import sys

from joshua_core.config_pb2 import TrainingConfig

XLA_FLAGS_VAR = "XLA_FLAGS"
# XLA's GPU programs use only deterministic algorithms: sorted scatters and reductions without atomics, and
# cuDNN/cuBLAS algorithms that repeat; no effect on the CPU, whose programs repeat already.
XLA_DETERMINISTIC_OPS = "--xla_gpu_deterministic_ops=true"


def use_determinism(training: TrainingConfig) -> bool:
    """With `training.deterministic`, add XLA's deterministic-ops flag to XLA_FLAGS (kept where already there) and
    return True; otherwise change nothing and return False. Warns when JAX has already started its backends, too
    late for the flag to take effect in this process."""
    if not training.deterministic:
        return False
    flags = os.environ.get(XLA_FLAGS_VAR, "").split()
    if XLA_DETERMINISTIC_OPS in flags:
        return True
    os.environ[XLA_FLAGS_VAR] = " ".join([*flags, XLA_DETERMINISTIC_OPS])
    if "jax" in sys.modules:
        from jax._src import xla_bridge  # no public way to ask whether JAX has started its backends

        if xla_bridge.backends_are_initialized():
            print(
                f"joshua: warning: training.deterministic: JAX started before {XLA_DETERMINISTIC_OPS} was set, so "
                "XLA runs without it in this process (no matter on the CPU); set training.deterministic before the "
                "first JAX computation",
                file=sys.stderr,
            )
    return True
