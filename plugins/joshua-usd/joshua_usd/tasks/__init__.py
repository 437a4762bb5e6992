"""The Isaac-convention tasks of joshua-usd: their specs (`specs`) and terms (`terms`).

This package stays light, because the plugin's task and term registrations point into it. As
stable-baselines3 VecEnvs they are joshua-sb3's `AntEnv` and `TrilegEnv` (`joshua_sb3.task_envs`).
"""
