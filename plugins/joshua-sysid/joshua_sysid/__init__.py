"""JOSHUA's system identification: `joshua sysid` fits position gains, joint damping, armature and friction
loss to recordings of commanded targets and measured joint positions, with mujoco.sysid.

The package itself imports nothing heavy (the `joshua` entry point is `joshua_sysid.plugin`); mujoco,
mujoco.sysid and matplotlib load only when the command runs. Exported for other plugins: `fit_of(model_path)`,
the fit (`Fit`: calibrated model file and its report.json) a model is or includes, or None.
"""

from joshua_sysid.calibrated import Fit, fit_of

__all__ = ["Fit", "fit_of"]
