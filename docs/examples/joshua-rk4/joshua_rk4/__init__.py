"""joshua-rk4: an example JOSHUA plugin that adds the `mujoco_rk4` backend and the `RK4_COMPARE` mode.

Kept empty on purpose: `joshua` imports `joshua_rk4.plugin`, and so this package, whenever it discovers plugins.
"""
