"""JOSHUA's system identification: `joshua sysid` fits position gains, joint damping, armature and friction
loss to recordings of commanded targets and measured joint positions, with mujoco.sysid.

The package itself imports nothing heavy (the `joshua` entry point is `joshua_sysid.plugin`); mujoco,
mujoco.sysid and matplotlib load only when the command runs.
"""

__all__: list[str] = []
