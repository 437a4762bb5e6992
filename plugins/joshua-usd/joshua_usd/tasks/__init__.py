"""The Isaac-convention tasks of joshua-usd: their specs (`specs`) and terms (`terms`).

This package stays light, because the plugin's task and term registrations point into it. The specs give the
tasks Isaac Lab's names as aliases (`AntEnv`, `TrilegEnv`), under which joshua-sb3 offers any task as a
stable-baselines3 VecEnv (`from joshua_sb3 import AntEnv`; `joshua_sb3.task_envs`).
"""
