"""Host side: running our FMUs under FMI hosts other than our own master.

``mechfmu.tools.hosts.libcosim``: one FMU under libcosim (through libcosimpy), see ``run_libcosim``.
Each host module imports its host library only when it is used, so importing this package
needs nothing beyond mechfmu's own dependencies.
"""
