"""mechfmu: mechanism models as FMI 2.0 co-simulation FMUs.

``mechfmu.runtime`` is what every FMU carries (standard library only); everything else is
host side.
"""

__version__ = "0.1.0"

# The public Python API, imported on first use (``import mechfmu`` stays cheap: no pandas
# until a name below is used): name -> module of the package that defines it.
_LAZY = {
    "compare": "comparison",
    "Comparison": "comparison",
}
__all__ = ["Comparison", "__version__", "compare"]  # and every name of _LAZY


def __getattr__(name: str) -> object:
    if name in _LAZY:
        from importlib import import_module
        return getattr(import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module 'mechfmu' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
