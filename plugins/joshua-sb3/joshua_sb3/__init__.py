"""JOSHUA's stable-baselines3 trainer (`sb3`): PPO, SAC or TD3 on the batched MuJoCo environments.

The package stays light (the `joshua` entry point imports `joshua_sb3.plugin`); torch and
stable-baselines3 are imported by `joshua_sb3.trainer` and `joshua_sb3.vec_env` when a run uses them.
"""
