"""Which implementation of MuJoCo's physics MJX runs for the environments: JAX (MJX's own) or MuJoCo Warp.

Both sit behind the same `mjx.step`/`mjx.forward` calls, so `joshua_mjx.env.MjxEnv` keeps one step, one set of
task terms, one randomization and one autoreset; what differs is made here: the device model, the initial
Data (Warp allocates contacts and constraint rows up front, `nconmax`/`njmax`), how a batch of Data is laid out
(Warp shares its contact arrays among the environments) and the overflow report. The option is
`training.mjx` (options.proto); docs/training-mjx.md#physics-implementation says how to choose.

Capacities, the rule: per environment, as many contacts and constraint rows as MJX-JAX allocates for the model
(its contacts are one per collision pair and contact point, its rows every one those contacts and the model's
joint limits, equalities and frictions can take), so a model that MJX-JAX steps never overflows on Warp;
`nconmax`/`njmax` replace them (smaller arrays cost less where few contacts are active at once).
"""

from __future__ import annotations

import atexit
import functools
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import jax
import jax.numpy as jnp
import mujoco
import numpy as np

from joshua_core.errors import ConfigError, ModelError
from joshua_jax import building_into
from joshua_mjx.engine import put_model as put_jax_model
from joshua_mjx.physics import mjx

if TYPE_CHECKING:
    from joshua_core.config_pb2 import TrainingConfig

JAX, WARP = "jax", "warp"
# Of MuJoCo Warp's overflow bits (mujoco_warp OverflowType), those that mean a capacity was too small, with the
# option that raises it; the others (the solver's iteration limits) are how a model with few iterations runs.
_CAPACITY_BITS = {1 << 0: "njmax", 1 << 2: "nconmax", 1 << 3: "nconmax", 1 << 4: "nconmax"}
# Rollouts between two clears of MuJoCo Warp's captured CUDA graphs (`CapturedGraphs`)
GRAPH_CLEAR_INTERVAL = 20
_JAX_MEMORY_VARIABLES = (
    "XLA_PYTHON_CLIENT_PREALLOCATE",
    "XLA_PYTHON_CLIENT_MEM_FRACTION",
    "XLA_PYTHON_CLIENT_ALLOCATOR",
)


@dataclass(frozen=True)
class Physics:
    """The implementation MJX steps the environments with, Warp's per-environment capacities (0: from the
    model, see the module docstring), and whether the run asks to repeat exactly (`training.deterministic`)."""

    impl: str = JAX
    nconmax: int = 0
    njmax: int = 0
    deterministic: bool = False

    def __post_init__(self) -> None:
        if self.nconmax < 0 or self.njmax < 0:
            raise ConfigError(f"training.mjx: nconmax and njmax must be 0 or more, got {self.nconmax}, {self.njmax}")

    @classmethod
    def from_training(cls, training: TrainingConfig | None) -> Physics:
        """The physics `training.mjx` names (MJX-JAX where the config names none)."""
        from joshua_mjx.options_pb2 import MjxOptions
        from joshua_mjx.options_pb2 import mjx as mjx_options

        if training is None:
            return cls()
        if not training.HasExtension(mjx_options):
            return cls(deterministic=training.deterministic)
        options = training.Extensions[mjx_options]
        impl = MjxOptions.Impl.Name(options.impl).lower()
        return cls(impl, options.nconmax, options.njmax, training.deterministic)

    def check_devices(self, devices: list[jax.Device]) -> None:
        """Refuse a device Warp cannot run on (Warp runs on CUDA GPUs and the CPU); warn that a deterministic run
        of Warp on a GPU will not repeat (docs/determinism.md)."""
        if self.impl != WARP:
            return
        for device in devices:
            if device.platform not in ("cpu", "gpu", "cuda"):
                raise ConfigError(f"training.mjx.impl WARP runs on a CUDA GPU or the CPU, not {device}")
        if self.deterministic and any(device.platform != "cpu" for device in devices):
            print(
                "joshua: warning: training.deterministic: MuJoCo Warp on a GPU sums contact and constraint forces "
                "with atomic additions in no fixed order, so runs will not repeat bit for bit; training.mjx.impl "
                "JAX repeats as far as XLA allows",
                file=sys.stderr,
            )

    def leave_memory_to_warp(self) -> None:
        """MuJoCo Warp allocates its work arrays outside JAX's memory pool, and JAX takes 75 % of a GPU up front by
        default, which can leave Warp too little: training then stops minutes in with "Failed to allocate".
        So JAX allocates on demand instead (XLA_PYTHON_CLIENT_PREALLOCATE=false), unless the
        user set JAX's memory variables; that must happen before JAX starts its backends, else it says what to do."""
        if self.impl != WARP or any(name in os.environ for name in _JAX_MEMORY_VARIABLES):
            return
        from jax._src import xla_bridge  # no public way to ask whether JAX has started its backends

        if not xla_bridge.backends_are_initialized():
            os.environ["XLA_PYTHON_CLIENT_PREALLOCATE"] = "false"
            return
        if jax.default_backend() == "gpu":
            print(
                "joshua: warning: MuJoCo Warp needs GPU memory outside JAX's pool, and JAX started before the "
                "environments with its default of 75 % of the GPU; set XLA_PYTHON_CLIENT_PREALLOCATE=false if "
                "training stops with 'Failed to allocate'",
                file=sys.stderr,
            )

    def put_model(
        self, model: mujoco.MjModel, source: str | Path, devices: list[jax.Device], **warp_options: Any
    ) -> Any:
        """`mjx.put_model` of this implementation on the first of `devices` (this process's devices the
        environments run on; Warp's kernels are loaded on each); a feature it does not support is one ModelError
        naming it. `warp_options`: MuJoCo Warp options to set (e.g. run_rne_postconstraint)."""
        device = devices[0]
        if self.impl == JAX:
            return put_jax_model(model, source, device)
        _require_warp()
        try:
            mjx_model = mjx.put_model(model, device=device, impl=WARP)
        except (NotImplementedError, ValueError) as error:
            raise ModelError(
                f"{source}: MuJoCo Warp does not support {_feature(error)}; use training.mjx.impl JAX"
            ) from None
        for each in devices:
            _load_warp_kernels(each)
        # warn_overflow 0: no message from every kernel of every step; `OverflowCheck` reports capacities once
        settings = {"warn_overflow": 0, **warp_options}
        return mjx_model.replace(opt=mjx_model.opt.replace(_impl=mjx_model.opt._impl.replace(**settings)))

    def put_data(self, model: mujoco.MjModel, data: mujoco.MjData, device: jax.Device, num_envs: int) -> Any:
        """`data` on `device` for this implementation, one environment's of the `num_envs` one device steps (Warp:
        with the contact capacity of all of them, which share one contact array, and the constraint rows of each;
        a batch of several devices' environments is made on each device, `MjxEnv._initial_batch`)."""
        if self.impl == JAX:
            return mjx.put_data(model, data, device=device, impl=JAX)
        nconmax, njmax = self.capacities(model)
        return mjx.put_data(model, data, device=device, impl=WARP, naconmax=nconmax * num_envs, njmax=njmax)

    def capacities(self, model: mujoco.MjModel) -> tuple[int, int]:
        """Warp's contacts and constraint rows per environment: the options', else MJX-JAX's for `model`."""
        if self.nconmax and self.njmax:
            return self.nconmax, self.njmax
        sizes = mjx.make_data(model, impl=JAX, device=jax.devices("cpu")[0])._impl
        return self.nconmax or max(sizes.contact.dist.shape[0], 1), self.njmax or max(sizes.efc_J.shape[0], 1)


def batch_data(data: Any, n: int) -> Any:
    """`n` copies of one environment's Data along a leading axis. A vmap, not a broadcast of every leaf: Warp's
    Data shares its contact arrays among the environments, and its vmapping rule keeps them unbatched."""
    return jax.vmap(lambda _: data)(jnp.arange(n))


def _load_warp_kernels(device: jax.Device) -> None:
    """Compile (or load from Warp's kernel cache) MuJoCo Warp's kernels on a GPU now, on every core at once.

    Left to Warp, each module compiles when a step first launches it, one after another, which makes a cold start
    several times longer than compiling them together. On the CPU, where compiling is Warp's development path, only
    what a step uses is built.
    Processes on one host take turns (`building_into`): the first builds on every core, the others then load.
    """
    if device.platform != "gpu":
        return
    import warp as wp

    wp.init()  # resolves the kernel cache folder
    folder = Path(wp.config.kernel_cache_dir) if wp.config.cache_kernels and wp.config.kernel_cache_dir else None
    with building_into(folder, "MuJoCo Warp's kernels"):
        wp.force_load(device=f"cuda:{device.local_hardware_id}", max_workers=os.cpu_count() or 1)


def _require_warp() -> None:
    """NVIDIA Warp, imported and logging only warnings (at its default level it prints a line for every kernel it
    loads), or a ConfigError saying what to install."""
    from mujoco.mjx import warp as mjx_warp

    if not mjx_warp.WARP_INSTALLED:
        raise ConfigError(
            "training.mjx.impl WARP needs NVIDIA Warp: pip install 'joshua-mjx[warp]' (warp-lang, mujoco-warp)"
        )
    mjx_warp.warp.config.log_level = mjx_warp.warp.LOG_WARNING
    _finish_warp_calls_at_exit()


@functools.cache  # once per process
def _finish_warp_calls_at_exit() -> None:
    """At interpreter exit, wait for every computation still in flight before Python finalizes. A MuJoCo Warp
    call runs as a Python callback on one of XLA's threads; one still queued at exit waits for the interpreter
    lock, which the exiting thread holds while it joins those threads, and the process hangs (a CPU run left
    with steps in flight hung at exit 3 times in 4)."""
    atexit.register(lambda: jax.block_until_ready(jax.live_arrays()))


def _feature(error: Exception) -> str:
    """The unsupported feature MuJoCo Warp's error names, as one line."""
    text = str(error).strip().rstrip(".").splitlines()
    return text[0] if text else type(error).__name__


class OverflowCheck:
    """Says once when a Warp environment overflowed a capacity (contacts or constraint rows dropped), naming the
    setting to raise. MuJoCo Warp keeps a per-environment overflow bitmask in the Data; `check` reads the one
    `watch` queued the time before, which the device has computed by then, so the check never waits on it."""

    def __init__(self, physics: Physics, model: mujoco.MjModel) -> None:
        self.enabled = physics.impl == WARP
        self.capacities = physics.capacities(model) if self.enabled else (0, 0)
        self._pending: jax.Array | None = None
        self._reported = False
        # each capacity bit's maximum over the environments: across devices a max-reduce, which every backend's
        # collectives have (the CPU's have no bitwise or)
        bits = jnp.asarray(sorted(_CAPACITY_BITS), jnp.int32)
        self._reduce = jax.jit(lambda overflow: jnp.max(overflow.reshape(-1, 1) & bits, axis=0))

    def watch(self, data: Any) -> None:
        """Report what the previous call queued, then queue `data`'s overflow bits (a batch of Warp Data)."""
        if not self.enabled or self._reported:
            return
        if self._pending is not None:
            self.report(int(np.bitwise_or.reduce(np.asarray(self._pending))))
        self._pending = self._reduce(data._impl.overflow)

    def report(self, bits: int) -> None:
        """Print, once, which capacity `bits` (OverflowType) says was exceeded and how to raise it."""
        names = sorted({name for bit, name in _CAPACITY_BITS.items() if bits & bit})
        if not names or self._reported:
            return
        self._reported = True
        current = dict(zip(("nconmax", "njmax"), self.capacities, strict=True))
        settings = ", ".join(f"training.mjx.{name} (now {current[name]})" for name in names)
        print(
            f"joshua: warning: MuJoCo Warp dropped {' and '.join(_WHAT[name] for name in names)} that did not fit; "
            f"raise {settings}",
            file=sys.stderr,
        )


_WHAT = {"nconmax": "contacts", "njmax": "constraint rows"}


class CapturedGraphs:
    """Keeps MuJoCo Warp's captured CUDA graphs from filling the GPU. On a GPU, Warp captures each call's kernels as
    a CUDA graph per set of buffer addresses (JaxCallableGraphMode.WARP) and keeps up to 32 of them per callable,
    each holding the work arrays it allocated while capturing. JAX hands the step new addresses now and then (an
    evaluation or a snapshot allocates in between), so graphs pile up until Warp fails to allocate minutes into a
    long run. Clearing them every GRAPH_CLEAR_INTERVAL rollouts, once the
    last one has finished, bounds that for one recapture per call site per interval."""

    def __init__(self, physics: Physics, device: jax.Device) -> None:
        self.enabled = physics.impl == WARP and device.platform == "gpu"
        self._rollouts = 0

    def between_rollouts(self, data: Any) -> None:
        """Count a rollout; every GRAPH_CLEAR_INTERVAL-th, wait for `data` (the last rollout's result, so that no
        graph is in flight) and clear every callable's graphs (`warp.clear_jax_callable_graph_cache`)."""
        if not self.enabled:
            return
        self._rollouts += 1
        if self._rollouts % GRAPH_CLEAR_INTERVAL == 0:
            import warp as wp

            jax.block_until_ready(data)
            wp.clear_jax_callable_graph_cache()
