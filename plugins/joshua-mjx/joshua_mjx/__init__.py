"""JOSHUA's MJX backend: JOSHUA tasks on thousands of MuJoCo XLA simulations inside `jax.jit`.

Import `joshua_mjx.env` (`MjxEnv`, `make_mjx_env`) or `joshua_mjx.engine` (`MjxEngine`); this
package module stays light because the plugin entry point imports it.
"""
