"""JOSHUA's USD plugin: UsdPhysics stages on MuJoCo physics (the `usd` backend and a reader for .usd
model files everywhere), MuJoCo -> USD export for Isaac, and the Isaac-convention tasks.

The package itself stays light (the `joshua` entry point imports `joshua_usd.plugin`).
"""
