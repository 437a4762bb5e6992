"""JOSHUA's JAX floor: what the plugins that compile with JAX (and Warp) share, so that a backend and a trainer
share it without importing each other.

A library (no `joshua` entry point): the compile cache between runs (`use_compile_cache`, `CompileCache`,
`cache_reads`) and the host-wide lock under which one process builds into a cache folder (`building_into`).
Importing it imports neither JAX nor Warp: `use_compile_cache` does, when it is called.
"""

from joshua_jax.compile_cache import CompileCache, building_into, cache_reads, use_compile_cache

__all__ = ["CompileCache", "building_into", "cache_reads", "use_compile_cache"]
