"""Numerics for the models: ODE integrators, small dense linear algebra, stepping through
events (standard library only: they run inside the FMUs)."""
