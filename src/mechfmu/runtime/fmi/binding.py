"""The FMI version this copy of the runtime serves: the base class of MechSlave.

The source tree, and so every in-process use and every FMI 2.0 FMU, binds to pythonfmu (FMI
2.0). ``mechfmu build --fmi-version 3`` rewrites this file in the FMU's own copy of the
runtime to bind to pythonfmu3 instead (fmi3.py); every FMU carries its own copy under its own
name, so FMUs of both versions live side by side in one process.
"""

from .fmi2 import Fmi2Binding as Binding  # noqa: F401
