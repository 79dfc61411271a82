"""Benchmarks of the master, the models and the effects: ``python -m mechfmu.tools.bench``.

Also ``mechfmu bench`` and ``make bench``; see the README section "Benchmarks". Timings are
reported against the issue's targets, never asserted: they depend on the machine.
"""


def main(argv=None) -> int:
    """Run the benchmarks with command-line arguments ``argv``; return the exit status."""
    from .cli import main as run_benchmarks
    return run_benchmarks(argv)
