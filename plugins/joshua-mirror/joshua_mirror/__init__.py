"""JOSHUA's MIRROR mode: a ROS 2 digital twin that mirrors a robot's encoder topics into MuJoCo.

The package itself stays light (the `joshua` entry point imports `joshua_mirror.plugin`); rclpy
and mujoco are imported only when the mode or the `mirror-replay` command runs.
"""
