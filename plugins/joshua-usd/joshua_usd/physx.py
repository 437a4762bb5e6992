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


class PhysxBatchPhysics(BatchPhysics):
    """`num_envs` clones of the stage's robot in one PhysX scene (see the module docstring)."""

    def __init__(self, model: mujoco.MjModel, stage_path: Path, num_envs: int, fields: frozenset[str]) -> None:
        missing = unavailable(fields)
        if missing:
            raise ConfigError(
                f"backend usd, physics PHYSX: the task's terms read {', '.join(missing)}, which PhysX does not give "
                f"(it gives {', '.join(sorted(FIELDS))})"
            )
        free = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE]
        if len(free) != 1 or model.jnt_qposadr[free[0]] != 0:
            raise ConfigError("backend usd, physics PHYSX: the robot needs one floating root (a free joint first)")
        self.model = model
        self.num_envs = num_envs
        self._actuator_dofs = _actuator_dofs(model)
        self._biased = bool(np.any(model.actuator_biastype != 0))
        ovphysx, ovstage = _ovphysx()
        from ovphysx.types import TensorType

        root = _articulation_root(stage_path)
        self._folder = tempfile.TemporaryDirectory(prefix="joshua-physx-")
        folder, contacts = Path(self._folder.name), "cfrc_ext" in fields
        stage_path = _prepared_stage(stage_path, root, folder, num_envs, contacts, gpu=_cuda_present())
        self._physx = physx = ovphysx.PhysX()
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

        def bind(tensor_type: int) -> Any:
            with warnings.catch_warnings():  # the tensor bindings are ovphysx 0.6's bulk (N, ...) numpy path
                warnings.simplefilter("ignore", DeprecationWarning)
                return physx.create_tensor_binding(prim_paths=paths, tensor_type=tensor_type, raise_if_empty=True)

        self._root_pose = bind(TensorType.ARTICULATION_ROOT_POSE)
        self._root_velocity = bind(TensorType.ARTICULATION_ROOT_VELOCITY)
        self._dof_position = bind(TensorType.ARTICULATION_DOF_POSITION)
        self._dof_velocity = bind(TensorType.ARTICULATION_DOF_VELOCITY)
        self._dof_force = bind(TensorType.ARTICULATION_DOF_ACTUATION_FORCE)
        self._link_pose = bind(TensorType.ARTICULATION_LINK_POSE)
        # MuJoCo's dofs and bodies in PhysX's columns, by name
        names = self._dof_position.dof_names
        dofs = {model.joint(j).name: j for j in range(model.njnt) if model.jnt_type[j] != mujoco.mjtJoint.mjJNT_FREE}
        if sorted(names) != sorted(dofs):
            raise ConfigError(f"{stage_path}: PhysX's joints {sorted(names)} are not the model's {sorted(dofs)}")
        self._qadr = np.array([model.jnt_qposadr[dofs[n]] for n in names])
        self._vadr = np.array([model.jnt_dofadr[dofs[n]] for n in names])
        self._column = {int(v): c for c, v in enumerate(self._vadr)}
        self._actuator_columns = np.array([self._column[int(d)] for d in self._actuator_dofs], dtype=np.intp)
        bodies = self._link_pose.body_names
        self._bodies = np.array([model.body(name).id for name in bodies])
        self._contacts = None
        if "cfrc_ext" in fields:
            self._sensors = [f"{p}/{b}" for p in paths for b in bodies]
            self._bind_contacts(CONTACTS_PER_LINK * len(self._sensors))
            robot = self._bodies
            self._body_ipos, self._body_mass = model.body_ipos[robot], model.body_mass[robot]
        self._switch_off_drives(TensorType, bind)
        nd = len(names)
        self._buffers = {
            "root_pose": np.zeros((num_envs, 7), np.float32),
            "root_velocity": np.zeros((num_envs, 6), np.float32),
            "dof_position": np.zeros((num_envs, nd), np.float32),
            "dof_velocity": np.zeros((num_envs, nd), np.float32),
            "dof_force": np.zeros((num_envs, nd), np.float32),
            "link_pose": np.zeros((num_envs, len(bodies), 7), np.float32),
        }
        self._limits = self._joint_limits(TensorType, bind)
        self._fields = {
            "qpos": np.tile(model.qpos0, (num_envs, 1)),
            "qvel": np.zeros((num_envs, model.nv)),
            "ctrl": np.zeros((num_envs, model.nu)),
            "xpos": np.zeros((num_envs, model.nbody, 3)),
            "xquat": np.tile([1.0, 0.0, 0.0, 0.0], (num_envs, model.nbody, 1)),
            "cfrc_ext": np.zeros((num_envs, model.nbody, 6)),
        }
        self._data = mujoco.MjData(model)

    def _bind_contacts(self, capacity: int) -> None:
        """The contact report of every link of every clone: net forces and up to `capacity` contact points
        (ovphysx's contact binding: rows in the order of the sensor paths, before the first step reported)."""
        if self._contacts is not None:
            self._contacts.destroy()
        with warnings.catch_warnings():  # the contact binding is ovphysx 0.6's bulk (N, 3) contact force
            warnings.simplefilter("ignore", DeprecationWarning)
            self._contacts = self._physx.create_contact_binding(self._sensors, max_contact_data_count=capacity)
        sensors = self._contacts.sensor_count
        self._contact_force = np.zeros((2, sensors, 3), np.float32)
        self._contact_points = (
            np.zeros((capacity, 1), np.float32),  # normal force (N)
            np.zeros((capacity, 3), np.float32),  # world position
            np.zeros((capacity, 3), np.float32),  # unit normal, towards the link
            np.zeros((capacity, 1), np.float32),  # separation
            np.zeros((sensors, 2), np.int32),  # per link: count, start
            np.zeros((capacity, 2), np.int64),  # actor ids
        )

    def _contact_torque(self, friction: NDArray[np.float64]) -> NDArray[np.float64]:
        """(num_envs, links, 3) torque of each link's contacts about its robot's centre of mass, in the world
        (MuJoCo's cfrc_ext torque); `friction` is each link's net friction force (sensors, 3)."""
        required = self._contacts.read_raw_contact_data(*self._contact_points)
        magnitude, position, normal, _, layout, _ = self._contact_points
        counts, starts = layout[:, 0].astype(np.intp), layout[:, 1].astype(np.intp)
        sensor = np.repeat(np.arange(len(counts)), counts)
        contact = np.repeat(starts - np.cumsum(counts) + counts, counts) + np.arange(counts.sum())
        envs, links = self.num_envs, len(self._bodies)
        centre = self._robot_com() + self.offsets  # world frame, as PhysX reports the contact points
        lever = position[contact].astype(np.float64) - centre[sensor // links]
        force = magnitude[contact].astype(np.float64) * normal[contact]
        torque = np.zeros((len(counts), 3))
        np.add.at(torque, sensor, np.cross(lever, force))
        weight, weighted = np.zeros(len(counts)), np.zeros((len(counts), 3))
        np.add.at(weight, sensor, magnitude[contact, 0])
        np.add.at(weighted, sensor, magnitude[contact] * lever)
        pressed = weight > 0
        torque[pressed] += np.cross(weighted[pressed] / weight[pressed, None], friction[pressed])
        if required > len(magnitude):  # this read kept the first contacts; the next ones get room for all
            self._bind_contacts(2 * required)
        return torque.reshape(envs, links, 3)

    def _robot_com(self) -> NDArray[np.float64]:
        """(num_envs, 3) centre of mass of each clone's links, relative to its lane (MuJoCo's subtree_com)."""
        xpos, xquat = self._fields["xpos"][:, self._bodies], self._fields["xquat"][:, self._bodies]
        envs, links = xpos.shape[:2]
        offset = np.broadcast_to(self._body_ipos, xpos.shape).reshape(-1, 3)
        xipos = xpos + _rotate(xquat.reshape(-1, 4), offset).reshape(envs, links, 3)
        return (xipos * self._body_mass[:, None]).sum(axis=1) / self._body_mass.sum()

    def _switch_off_drives(self, tensor_type: Any, bind: Any) -> None:
        """Zero the PhysX drive gains of actuated joints: their effort comes from MuJoCo's actuator law."""
        for kind in (tensor_type.ARTICULATION_DOF_STIFFNESS, tensor_type.ARTICULATION_DOF_DAMPING):
            binding = bind(kind)
            gains = np.zeros(binding.shape, np.float32)
            binding.read(gains)
            gains[:, self._actuator_columns] = 0.0
            binding.write(gains)
            binding.destroy()

    def _joint_limits(self, tensor_type: Any, bind: Any) -> NDArray[np.float32]:
        """(num_envs, dofs, 2) joint limits (radians): written positions are held inside them."""
        binding = bind(tensor_type.ARTICULATION_DOF_LIMIT)
        limits = np.zeros(binding.shape, np.float32)
        binding.read(limits)
        binding.destroy()
        return limits

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
        qpos, qvel, b = self._fields["qpos"], self._fields["qvel"], self._buffers
        index = np.asarray(ids, dtype=np.int32)
        b["root_pose"][ids, :3] = qpos[ids, :3] + self.offsets[ids]
        b["root_pose"][ids, 3:6] = qpos[ids, 4:7]
        b["root_pose"][ids, 6] = qpos[ids, 3]
        quat = qpos[ids, 3:7]
        b["root_velocity"][ids, :3] = qvel[ids, :3]
        b["root_velocity"][ids, 3:] = _rotate(quat, qvel[ids, 3:6])
        limits = self._limits[ids]
        b["dof_position"][ids] = np.clip(qpos[ids][:, self._qadr], limits[..., 0], limits[..., 1])
        b["dof_velocity"][ids] = qvel[ids][:, self._vadr]
        b["dof_force"][ids] = 0.0
        for binding, name in (
            (self._root_pose, "root_pose"),
            (self._root_velocity, "root_velocity"),
            (self._dof_position, "dof_position"),
            (self._dof_velocity, "dof_velocity"),
            (self._dof_force, "dof_force"),
        ):
            binding.write(b[name], indices=index)
        self._physx.update_articulations_kinematic()
        self._read()
        self._fields["cfrc_ext"][ids] = 0.0

    def step(self, nstep: int) -> NDArray[np.bool_]:
        dt = float(self.model.opt.timestep)
        for _ in range(nstep):
            self._apply_ctrl()
            self._physx.step_sync(dt)
            if self._biased:
                self._read()
        if not self._biased:
            self._read()
        return np.zeros(self.num_envs, dtype=bool)

    def _apply_ctrl(self) -> None:
        """MuJoCo's actuator force (gain * ctrl + bias) times the gear, clamped, as each joint's PhysX effort."""
        model, qpos, qvel = self.model, self._fields["qpos"], self._fields["qvel"]
        ctrl = self._fields["ctrl"]
        if model.actuator_ctrllimited.any():
            low, high = model.actuator_ctrlrange.T
            ctrl = np.where(model.actuator_ctrllimited, np.clip(ctrl, low, high), ctrl)
        joints = model.actuator_trnid[:, 0]
        force = model.actuator_gainprm[:, 0] * ctrl
        force += model.actuator_biasprm[:, 0]
        force += model.actuator_biasprm[:, 1] * qpos[:, model.jnt_qposadr[joints]]
        force += model.actuator_biasprm[:, 2] * qvel[:, self._actuator_dofs]
        if model.actuator_forcelimited.any():
            low, high = model.actuator_forcerange.T
            force = np.where(model.actuator_forcelimited, np.clip(force, low, high), force)
        effort = self._buffers["dof_force"]
        effort[:] = 0.0
        np.add.at(effort, (slice(None), self._actuator_columns), force * model.actuator_gear[:, 0])
        self._dof_force.write(effort)

    def _read(self) -> None:
        """PhysX's state into the MuJoCo-layout fields."""
        b, f = self._buffers, self._fields
        self._root_pose.read(b["root_pose"])
        self._root_velocity.read(b["root_velocity"])
        self._dof_position.read(b["dof_position"])
        self._dof_velocity.read(b["dof_velocity"])
        self._link_pose.read(b["link_pose"])
        pose = b["root_pose"].astype(np.float64)
        f["qpos"][:, :3] = pose[:, :3] - self.offsets
        f["qpos"][:, 3] = pose[:, 6]
        f["qpos"][:, 4:7] = pose[:, 3:6]
        f["qpos"][:, self._qadr] = b["dof_position"]
        velocity = b["root_velocity"].astype(np.float64)
        f["qvel"][:, :3] = velocity[:, :3]
        f["qvel"][:, 3:6] = _rotate(_conjugate(f["qpos"][:, 3:7]), velocity[:, 3:])
        f["qvel"][:, self._vadr] = b["dof_velocity"]
        links = b["link_pose"].astype(np.float64)
        f["xpos"][:, self._bodies] = links[..., :3] - self.offsets[:, None]
        f["xquat"][:, self._bodies, 0] = links[..., 6]
        f["xquat"][:, self._bodies, 1:] = links[..., 3:6]
        if self._contacts is not None:
            self._contacts.read_net_normal_forces(self._contact_force[0])
            self._contacts.read_net_friction_forces(self._contact_force[1])
            forces = self._contact_force.sum(axis=0).reshape(self.num_envs, len(self._bodies), 3)
            f["cfrc_ext"][:, self._bodies, :3] = self._contact_torque(self._contact_force[1].astype(np.float64))
            f["cfrc_ext"][:, self._bodies, 3:] = forces

    def model_and_data(self, env_index: int) -> tuple[mujoco.MjModel, mujoco.MjData]:
        self._data.qpos[:] = self._fields["qpos"][env_index]
        self._data.qvel[:] = self._fields["qvel"][env_index]
        mujoco.mj_forward(self.model, self._data)
        return self.model, self._data

    def close(self) -> None:
        physx = self.__dict__.pop("_physx", None)
        if physx is None:
            return
        if self._contacts is not None:
            self._contacts.destroy()
        for binding in (
            self._root_pose, self._root_velocity, self._dof_position, self._dof_velocity, self._dof_force,
            self._link_pose,
        ):  # fmt: skip
            binding.destroy()
        physx.wait_task(physx.detach_ovstage())
        self._stage.destroy()
        physx.destroy()
        self._folder.cleanup()


@functools.cache
def _cuda_present() -> bool:
    """Whether a CUDA device is visible (GPU PhysX); CPU PhysX otherwise. Asked once per process: PhysX's mode is
    a process-wide setting (`_ovphysx`), and every scene's GPU buffers follow the same answer."""
    import warp

    warp.config.quiet = True
    warp.init()
    return bool(warp.get_cuda_device_count())


def _conjugate(quat: NDArray[np.float64]) -> NDArray[np.float64]:
    return quat * np.array([1.0, -1.0, -1.0, -1.0])


def _rotate(quat: NDArray[np.float64], vector: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotate (N, 3) vectors by (N, 4) w-first unit quaternions."""
    w, u = quat[:, :1], quat[:, 1:]
    return vector + 2.0 * np.cross(u, np.cross(u, vector) + w * vector)
