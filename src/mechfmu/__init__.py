"""mechfmu: mechanism models as FMI 2.0 co-simulation FMUs.

``mechfmu.runtime`` is what every FMU carries (standard library only); everything else is
host side. The Python API returns pandas DataFrames::

    import mechfmu
    df = mechfmu.simulate("gear_retraction")          # index time (s), one column per output
    ref = mechfmu.reference("gear_retraction")        # its closed form on the same grid
    mechfmu.write_result(df, "out/gear.csv")          # the CSV + JSON pair of mechfmu run
    df = mechfmu.read_result("out/gear.csv")
    cam = mechfmu.cam_profile("valve_train")         # the valve train's cam, one row per angle
    mechfmu.animate(mechfmu.simulate("four_bar_crank_rocker", geometry=True))  # see it move

The API is imported on first use, so ``import mechfmu`` (and the command line) stays light.
"""

from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

# The public Python API, imported on first use (``import mechfmu`` stays cheap: no pandas
# until a name below is used): name -> module of the package that defines it.
_API = {
    "simulate": "api",
    "reference": "api",
    "cam_profile": "tools.cam_design",
    "sweep": "api",
    "animate": "tools.animate",
    "read_result": "io",
    "write_result": "io",
    "read_table": "io",
    "ResultFileError": "io",
    "compare": "comparison",
    "Comparison": "comparison",
}

__all__ = [
    "Comparison",
    "animate",
    "ResultFileError",
    "__version__",
    "cam_profile",
    "compare",
    "read_result",
    "read_table",
    "reference",
    "simulate",
    "sweep",
    "write_result",
]  # _API's names

if TYPE_CHECKING:
    from .api import reference, simulate, sweep
    from .comparison import Comparison, compare
    from .io import ResultFileError, read_result, read_table, write_result
    from .tools.cam_design import cam_profile
    from .tools.animate import animate


def __getattr__(name: str) -> Any:
    module = _API.get(name)
    if module is None:
        raise AttributeError(f"module 'mechfmu' has no attribute {name!r}")
    from importlib import import_module

    value = getattr(import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list:
    return sorted([*globals(), *_API])
