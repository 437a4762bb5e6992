"""PhysX physics for the `usd` backend's NUMPY environments: `BatchPhysics` on NVIDIA's standalone PhysX.

One PhysX scene holds the stage's robot cloned `num_envs` times (ovphysx's clone), each copy in its own
lane `ENV_SPACING` apart (CPU PhysX has no per-environment collision filtering: ovphysx
docs/tutorials/cloning.md). State crosses in MuJoCo's layout of the model our importer compiles from
the same stage, so the task terms, resets and autoreset are joshua-mujoco's `BatchedSimulation`'s:

- qpos/qvel: the root's pose and velocity (position relative to its lane, quaternion w-first, angular
  velocity in the root's frame as MuJoCo's free joint has it) and each hinge/slide joint's position and
  velocity (radians), matched by joint name.
- ctrl: MuJoCo's actuator law, force = gain * ctrl + bias(q, qdot) times the gear, clamped to its
  range, evaluated on the PhysX state before each physics step and applied as joint effort (the
  stage's PhysX drives on actuated joints are switched off so that nothing acts twice).
- xpos/xquat: link poses; cfrc_ext: each link's contact wrench as MuJoCo defines it (world frame,
  [torque; force], the torque about the centre of mass of the link's whole robot, MuJoCo's
  `subtree_com` of its root): the force is the net normal plus friction force of PhysX's contact
  report; the torque sums each contact point's normal force about that centre (ovphysx's raw contact
  data), with the net friction force applied at the links' normal-force-weighted contact centre
  (friction anchors come only with filtered bindings: exact for one contact point, e.g. a foot).

Anything else a term reads (sites, sensors, model fields) is refused when the environments are built.
"""

from __future__ import annotations

import functools
import logging
import tempfile
import warnings
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from joshua_core.errors import ConfigError
from joshua_mujoco import BatchPhysics
from joshua_usd.physx_state import contact_wrench, from_physx, robot_com, to_physx

CONTACTS_PER_LINK = 16  # room for contact points per link and read; grown when a step reports more
ENV_SPACING = 20.0  # metres between the lanes of the clones: further than a robot walks in an episode
# GPU PhysX's buffers (PhysxSceneAPI, ovphysx docs/population/PhysxSceneAPI.md): (per clone, schema default), the
# larger of default and per clone x clones authored. With the defaults, 4096 and 8192 Ants on a GPU logged
# "needs to increase totalAggregatePairsCapacity to 1025-2047 / foundLostAggregatePairsCapacity to 5845, otherwise
# the simulation will miss interactions" (each articulation is an aggregate): 8 pairs per clone leaves room.
GPU_CAPACITIES = {
    "gpuTotalAggregatePairsCapacity": (8, 1024),
    "gpuFoundLostAggregatePairsCapacity": (8, 1024),
    "gpuFoundLostPairsCapacity": (64, 262144),
    "gpuMaxRigidContactCount": (128, 524288),
    "gpuMaxRigidPatchCount": (32, 81920),
}
# The state fields this physics gives (BatchPhysics.field).
FIELDS = frozenset({"qpos", "qvel", "ctrl", "xpos", "xquat", "cfrc_ext"})
PHYSX_MISSING = (
    "backend usd, physics PHYSX: needs NVIDIA's ovphysx, which is not installed; pip install 'joshua-usd[physx]'"
)
PHYSX_NOT_LOADING = "backend usd, physics PHYSX: ovphysx is installed but its native library does not load"
_schemas_registered = False


class _Warnings(logging.Handler):
    """The first warning logged while it is attached, on one line."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.first = ""

    def emit(self, record: logging.LogRecord) -> None:
        self.first = self.first or " ".join(record.getMessage().split())


def _ovphysx() -> Any:
    """ovphysx and ovstage, set up once per process before the first PhysX instance: CPU PhysX unless CUDA is
    present (a process-wide startup setting), the PhysX USD schemas registered (ovphysx SKILLS.md)."""
    global _schemas_registered
    # ovphysx logs why its bundled library failed and then raises about the fallback it tried next (the
    # system's library path): the logged reason is the one that names the missing piece
    logged = _Warnings()
    logging.getLogger("ovphysx").addHandler(logged)
    try:
        import ovphysx
        import ovstage

        physx = ovphysx.PhysX  # ovphysx loads its native library at the first use of its API
    except ModuleNotFoundError as error:
        if error.name not in ("ovphysx", "ovstage"):
            raise
        raise ConfigError(PHYSX_MISSING) from None
    except OSError as error:
        reason = logged.first or (str(error).strip().splitlines() or [type(error).__name__])[0]
        raise ConfigError(f"{PHYSX_NOT_LOADING}: {reason}") from None
    finally:
        logging.getLogger("ovphysx").removeHandler(logged)
    from ovphysx.samples.python_samples.schema_support import physx_schema_paths

    if not _schemas_registered:
        physx.set_cpu_mode(not _cuda_present())
        ovstage.population.register_usd_schemas([str(path) for path in physx_schema_paths()])
        _schemas_registered = True
    return ovphysx, ovstage


def unavailable(fields: frozenset[str]) -> list[str]:
    """The state fields among `fields` that PhysX physics does not give."""
    return sorted(fields - FIELDS - {"action", "prev_qpos", "prev_action", "episode_step", "commands"})


def _actuator_dofs(model: mujoco.MjModel) -> NDArray[np.intp]:
    """Each actuator's joint's dof address; refuses an actuator MuJoCo's affine law on a joint doesn't cover."""
    for i in range(model.nu):
        name = model.actuator(i).name or str(i)
        if model.actuator_trntype[i] != mujoco.mjtTrn.mjTRN_JOINT:
            raise ConfigError(f"backend usd, physics PHYSX: actuator {name} does not act on a joint")
        if model.actuator_dyntype[i] != mujoco.mjtDyn.mjDYN_NONE or model.actuator_gaintype[i] != 0:
            raise ConfigError(f"backend usd, physics PHYSX: actuator {name} has activation or a non-fixed gain")
    return model.jnt_dofadr[model.actuator_trnid[:, 0]]


def _articulation_root(stage_path: Path) -> str:
    """The path of the stage's one articulation root prim."""
    from pxr import Usd, UsdPhysics

    stage = Usd.Stage.Open(str(stage_path))
    roots = [str(p.GetPath()) for p in stage.Traverse() if p.HasAPI(UsdPhysics.ArticulationRootAPI)]
    if len(roots) != 1:
        raise ConfigError(f"{stage_path}: PhysX environments need one articulation root, found {roots or 'none'}")
    return roots[0]


def _prepared_stage(stage_path: Path, root: str, folder: Path, num_envs: int, contacts: bool, gpu: bool) -> Path:
    """The stage to open, in `folder`: a copy whose articulation links report every contact (PhysxContactReportAPI,
    threshold 0, as the exporter authors it on contact-sensor bodies) when `contacts`, and whose PhysicsScene's GPU
    buffers are sized for `num_envs` clones when `gpu` (`GPU_CAPACITIES`); `stage_path` itself when neither."""
    if not (contacts or gpu):
        return stage_path
    from pxr import Sdf, Usd, UsdPhysics

    from joshua_usd.exporter.context import set_physx

    stage = Usd.Stage.Open(str(stage_path))
    if contacts:
        for prim in Usd.PrimRange(stage.GetPrimAtPath(root)):
            if prim.HasAPI(UsdPhysics.RigidBodyAPI):
                set_physx(prim, "PhysxContactReportAPI", "threshold", Sdf.ValueTypeNames.Float, 0.0)
    if gpu:
        for scene in (prim for prim in stage.Traverse() if prim.IsA(UsdPhysics.Scene)):
            for name, (per_env, default) in GPU_CAPACITIES.items():
                set_physx(scene, "PhysxSceneAPI", name, Sdf.ValueTypeNames.UInt, max(default, per_env * num_envs))
    path = folder / "stage.usda"
    stage.Export(str(path))
    return path


class PhysxScene:
    """The stage's robot cloned `num_envs` times in one PhysX scene, each clone in its lane (`offsets`), with the
    tensor bindings of its state and MuJoCo's names for PhysX's columns. Shared by the NUMPY environments
    (`PhysxBatchPhysics`, numpy buffers) and the JAX ones (`joshua_usd.physx_jax`, device buffers); `direct_gpu`
    keeps PhysX's state on the GPU (its tensors are then read and written as CUDA arrays only)."""

    def __init__(
        self, model: mujoco.MjModel, stage_path: Path, num_envs: int, contacts: bool, *, direct_gpu: bool = False
    ) -> None:
        free = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE]
        if len(free) != 1 or model.jnt_qposadr[free[0]] != 0:
            raise ConfigError("backend usd, physics PHYSX: the robot needs one floating root (a free joint first)")
        self.model = model
        self.num_envs = num_envs
        self.actuator_dofs = _actuator_dofs(model)
        self.biased = bool(np.any(model.actuator_biastype != 0))
        ovphysx, ovstage = _ovphysx()
        from ovphysx.types import TensorType

        root = _articulation_root(stage_path)
        self._folder = tempfile.TemporaryDirectory(prefix="joshua-physx-")
        stage_path = _prepared_stage(stage_path, root, Path(self._folder.name), num_envs, contacts, _cuda_present())
        if direct_gpu:  # PhysX's state stays on the GPU (ovphysx skills/tensor-bindings-gpu)
            config = ovphysx.PhysXConfig(carbonite_overrides={"/physics/suppressReadback": True})
            self.physx = physx = ovphysx.PhysX(config=config)
        else:
            self.physx = physx = ovphysx.PhysX()
        self._stage = ovstage.Stage(f"joshua-physx-{id(self)}")
        ovstage.population.open_usd(self._stage, str(stage_path), ordinal=1, domains=ovstage.PopulationDomain.ALL)
        self._stage.advance_write_floor(ordinal=1).wait()
        physx.wait_task(physx.attach_ovstage(self._stage, read_ordinal=1))
        side = int(np.ceil(np.sqrt(num_envs)))
        self.offsets = np.array([[ENV_SPACING * (i % side), ENV_SPACING * (i // side), 0.0] for i in range(num_envs)])
        paths = [root] + [f"{root}_env{i}" for i in range(1, num_envs)]
        if num_envs > 1:
            anchors = [(*offset, 0.0, 0.0, 0.0, 1.0) for offset in self.offsets[1:]]
            physx.wait_task(physx.clone(root, paths[1:], anchor_transforms=anchors))
        physx.wait_all()
        physx.warmup()
        self._paths = paths

        self.root_pose = self.bind(TensorType.ARTICULATION_ROOT_POSE)
        self.root_velocity = self.bind(TensorType.ARTICULATION_ROOT_VELOCITY)
        self.dof_position = self.bind(TensorType.ARTICULATION_DOF_POSITION)
        self.dof_velocity = self.bind(TensorType.ARTICULATION_DOF_VELOCITY)
        self.dof_force = self.bind(TensorType.ARTICULATION_DOF_ACTUATION_FORCE)
        self.link_pose = self.bind(TensorType.ARTICULATION_LINK_POSE)
        # MuJoCo's dofs and bodies in PhysX's columns, by name
        names = self.dof_position.dof_names
        dofs = {model.joint(j).name: j for j in range(model.njnt) if model.jnt_type[j] != mujoco.mjtJoint.mjJNT_FREE}
        if sorted(names) != sorted(dofs):
            raise ConfigError(f"{stage_path}: PhysX's joints {sorted(names)} are not the model's {sorted(dofs)}")
        self.qadr = np.array([model.jnt_qposadr[dofs[n]] for n in names])
        self.vadr = np.array([model.jnt_dofadr[dofs[n]] for n in names])
        column = {int(v): c for c, v in enumerate(self.vadr)}
        self.actuator_columns = np.array([column[int(d)] for d in self.actuator_dofs], dtype=np.intp)
        self._placement = np.zeros((model.nu, len(self.vadr)))  # each actuator's gear in its joint's column
        self._placement[np.arange(model.nu), self.actuator_columns] = model.actuator_gear[:, 0]
        self.bodies = np.array([model.body(name).id for name in self.link_pose.body_names])
        self.contacts: Any = None
        self.sensors = [f"{p}/{b}" for p in paths for b in self.link_pose.body_names] if contacts else []
        if contacts:
            self.bind_contacts(CONTACTS_PER_LINK * len(self.sensors))
        self._switch_off_drives(TensorType)
        self.limits = self._joint_limits(TensorType)

    def bind(self, tensor_type: int) -> Any:
        """A tensor binding of `tensor_type` over every clone."""
        with warnings.catch_warnings():  # the tensor bindings are ovphysx 0.6's bulk (N, ...) path
            warnings.simplefilter("ignore", DeprecationWarning)
            return self.physx.create_tensor_binding(
                prim_paths=self._paths, tensor_type=tensor_type, raise_if_empty=True
            )

    def bind_contacts(self, capacity: int) -> None:
        """The contact report of every link of every clone: net forces and up to `capacity` contact points
        (ovphysx's contact binding: rows in the order of the sensor paths, before the first step reported)."""
        if self.contacts is not None:
            self.contacts.destroy()
        with warnings.catch_warnings():  # the contact binding is ovphysx 0.6's bulk (N, 3) contact force
            warnings.simplefilter("ignore", DeprecationWarning)
            self.contacts = self.physx.create_contact_binding(self.sensors, max_contact_data_count=capacity)
        self.contact_capacity = capacity

    def _switch_off_drives(self, tensor_type: Any) -> None:
        """Zero the PhysX drive gains of actuated joints: their effort comes from MuJoCo's actuator law."""
        for kind in (tensor_type.ARTICULATION_DOF_STIFFNESS, tensor_type.ARTICULATION_DOF_DAMPING):
            binding = self.bind(kind)
            gains = np.zeros(binding.shape, np.float32)
            binding.read(gains)
            gains[:, self.actuator_columns] = 0.0
            binding.write(gains)
            binding.destroy()

    def _joint_limits(self, tensor_type: Any) -> NDArray[np.float32]:
        """(num_envs, dofs, 2) joint limits (radians): written positions are held inside them."""
        binding = self.bind(tensor_type.ARTICULATION_DOF_LIMIT)
        limits = np.zeros(binding.shape, np.float32)
        binding.read(limits)
        binding.destroy()
        return limits

    def effort(self, xp: Any, ctrl: Any, qpos: Any, qvel: Any, gain: Any = None, bias: Any = None) -> Any:
        """(num_envs, dofs) joint efforts in PhysX's columns: MuJoCo's actuator force (gain * ctrl + bias(q, qdot),
        ctrl and force clamped to their ranges) times the gear, on numpy or jax.numpy (`xp`). `gain`/`bias`:
        each environment's actuator_gainprm/biasprm (N, nu, 10) where they are randomized, else the model's."""
        model = self.model
        gain = model.actuator_gainprm if gain is None else gain
        bias = model.actuator_biasprm if bias is None else bias
        if model.actuator_ctrllimited.any():
            low, high = model.actuator_ctrlrange.T
            ctrl = xp.where(model.actuator_ctrllimited, xp.clip(ctrl, low, high), ctrl)
        q = qpos[:, model.jnt_qposadr[model.actuator_trnid[:, 0]]]
        force = gain[..., 0] * ctrl + bias[..., 0] + bias[..., 1] * q + bias[..., 2] * qvel[:, self.actuator_dofs]
        if model.actuator_forcelimited.any():
            low, high = model.actuator_forcerange.T
            force = xp.where(model.actuator_forcelimited, xp.clip(force, low, high), force)
        return force @ self._placement.astype(force.dtype)

    def close(self) -> None:
        physx = self.__dict__.pop("physx", None)
        if physx is None:
            return
        if self.contacts is not None:
            self.contacts.destroy()
        for binding in (
            self.root_pose, self.root_velocity, self.dof_position, self.dof_velocity, self.dof_force, self.link_pose,
        ):  # fmt: skip
            binding.destroy()
        physx.wait_task(physx.detach_ovstage())
        self._stage.destroy()
        physx.destroy()
        self._folder.cleanup()


class PhysxBatchPhysics(BatchPhysics):
    """`num_envs` clones of the stage's robot in one PhysX scene (see the module docstring)."""

    def __init__(self, model: mujoco.MjModel, stage_path: Path, num_envs: int, fields: frozenset[str]) -> None:
        missing = unavailable(fields)
        if missing:
            raise ConfigError(
                f"backend usd, physics PHYSX: the task's terms read {', '.join(missing)}, which PhysX does not give "
                f"(it gives {', '.join(sorted(FIELDS))})"
            )
        self.model = model
        self.num_envs = num_envs
        self.scene = scene = PhysxScene(model, stage_path, num_envs, "cfrc_ext" in fields)
        self._contacts: Any = None
        if scene.contacts is not None:
            from joshua_usd.physx_contacts import SUMS, ContactReader

            self._contacts = ContactReader(scene, "cpu")
            links = len(scene.sensors)
            self._contact_arrays = (
                np.zeros((links, 3), np.float32), np.zeros((links, 3), np.float32), np.zeros((links, SUMS), np.float32)
            )  # fmt: skip
            self._inertia = (model.body_ipos[scene.bodies], model.body_mass[scene.bodies])
        nd = len(scene.vadr)
        self._buffers = {
            "root_pose": np.zeros((num_envs, 7), np.float32),
            "root_velocity": np.zeros((num_envs, 6), np.float32),
            "dof_position": np.zeros((num_envs, nd), np.float32),
            "dof_velocity": np.zeros((num_envs, nd), np.float32),
            "dof_force": np.zeros((num_envs, nd), np.float32),
            "link_pose": np.zeros((num_envs, len(scene.bodies), 7), np.float32),
        }
        self._fields = {
            "qpos": np.tile(model.qpos0, (num_envs, 1)),
            "qvel": np.zeros((num_envs, model.nv)),
            "ctrl": np.zeros((num_envs, model.nu)),
            "xpos": np.zeros((num_envs, model.nbody, 3)),
            "xquat": np.tile([1.0, 0.0, 0.0, 0.0], (num_envs, model.nbody, 1)),
            "cfrc_ext": np.zeros((num_envs, model.nbody, 6)),
        }
        self._data = mujoco.MjData(model)

    @property
    def nthread(self) -> int:
        return 1

    def field(self, name: str) -> NDArray[np.float64]:
        if name not in self._fields:
            raise ConfigError(f"backend usd, physics PHYSX: PhysX does not give {name}")
        return self._fields[name]

    def model_field(self, name: str) -> NDArray[np.float64]:
        raise ConfigError(f"backend usd, physics PHYSX: randomizing {name} is not supported on PhysX")

    def set_const(self, ids: NDArray[np.intp]) -> None:
        raise ConfigError("backend usd, physics PHYSX: randomized model fields are not supported on PhysX")

    def reset(self, ids: NDArray[np.intp], keyframe: int | None) -> None:
        model, key = self.model, keyframe if keyframe is not None and keyframe >= 0 else None
        self._fields["qpos"][ids] = model.qpos0 if key is None else model.key_qpos[key]
        self._fields["qvel"][ids] = 0.0 if key is None else model.key_qvel[key]
        self._fields["ctrl"][ids] = 0.0 if key is None else model.key_ctrl[key]

    def forward(self, ids: NDArray[np.intp]) -> None:
        """Write the state of `ids` into PhysX (joint positions held inside their limits), then read all back."""
        if not len(ids):
            return
        scene, b = self.scene, self._buffers
        pose, velocity, position, dof_velocity = to_physx(
            np, self._fields["qpos"][ids], self._fields["qvel"][ids], scene.offsets[ids], scene.qadr, scene.vadr,
            scene.limits[ids],
        )  # fmt: skip
        b["root_pose"][ids], b["root_velocity"][ids] = pose, velocity
        b["dof_position"][ids], b["dof_velocity"][ids] = position, dof_velocity
        b["dof_force"][ids] = 0.0
        index = np.asarray(ids, dtype=np.int32)
        for name in ("root_pose", "root_velocity", "dof_position", "dof_velocity", "dof_force"):
            getattr(scene, name).write(b[name], indices=index)
        scene.physx.update_articulations_kinematic()
        self._read()
        self._fields["cfrc_ext"][ids] = 0.0

    def step(self, nstep: int) -> NDArray[np.bool_]:
        scene, f, dt = self.scene, self._fields, float(self.model.opt.timestep)
        for _ in range(nstep):
            effort = scene.effort(np, f["ctrl"], f["qpos"], f["qvel"])
            self._buffers["dof_force"][:] = effort
            scene.dof_force.write(self._buffers["dof_force"])
            scene.physx.step_sync(dt)
            if scene.biased:
                self._read()
        if not scene.biased:
            self._read()
        return np.zeros(self.num_envs, dtype=bool)

    def _read(self) -> None:
        """PhysX's state into the MuJoCo-layout fields."""
        scene, b, f = self.scene, self._buffers, self._fields
        for name in ("root_pose", "root_velocity", "dof_position", "dof_velocity", "link_pose"):
            getattr(scene, name).read(b[name])
        qpos, qvel = from_physx(
            np, f["qpos"], f["qvel"], b["root_pose"].astype(np.float64), b["root_velocity"].astype(np.float64),
            b["dof_position"], b["dof_velocity"], scene.offsets, scene.qadr, scene.vadr,
        )  # fmt: skip
        f["qpos"][:], f["qvel"][:] = qpos, qvel
        links = b["link_pose"].astype(np.float64)
        f["xpos"][:, scene.bodies] = links[..., :3] - scene.offsets[:, None]
        f["xquat"][:, scene.bodies, 0] = links[..., 6]
        f["xquat"][:, scene.bodies, 1:] = links[..., 3:6]
        if self._contacts is not None:
            normal, friction, sums = self._contact_arrays
            self._contacts.read(normal, friction, sums)
            links_shape = (self.num_envs, len(scene.bodies))
            centre = robot_com(np, f["xpos"][:, scene.bodies], f["xquat"][:, scene.bodies], *self._inertia)
            wrench = contact_wrench(
                np, *(a.reshape(*links_shape, -1).astype(np.float64) for a in (normal, friction, sums)), centre
            )
            f["cfrc_ext"][:, scene.bodies] = wrench

    def model_and_data(self, env_index: int) -> tuple[mujoco.MjModel, mujoco.MjData]:
        self._data.qpos[:] = self._fields["qpos"][env_index]
        self._data.qvel[:] = self._fields["qvel"][env_index]
        mujoco.mj_forward(self.model, self._data)
        return self.model, self._data

    def close(self) -> None:
        self.scene.close()


@functools.cache
def _cuda_present() -> bool:
    """Whether a CUDA device is visible (GPU PhysX); CPU PhysX otherwise. Asked once per process: PhysX's mode is
    a process-wide setting (`_ovphysx`), and every scene's GPU buffers follow the same answer."""
    import warp

    warp.config.quiet = True
    warp.init()
    return bool(warp.get_cuda_device_count())
