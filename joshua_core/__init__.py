"""JOSHUA core: plugin interfaces, configuration and the `joshua` command line.

Light on purpose: importing it pulls in protobuf, pluggy and numpy, never a physics or ML stack.
"""

from joshua_core.hookspecs import hookimpl

__version__ = "0.1.0"

__all__ = ["__version__", "hookimpl"]
