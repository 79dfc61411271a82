"""The FMU runtime: everything that runs inside an FMU (standard library only).

``mechfmu build`` copies this package, and nothing else of mechfmu, into every FMU:
``numerics`` (integrators, linear algebra, stepping through events), ``physics`` (the
mechanism equations), ``fmi`` (the slave base classes over pythonfmu) and ``models`` (one
class per FMU). Keep it free of imports beyond the standard library and pythonfmu.
"""
