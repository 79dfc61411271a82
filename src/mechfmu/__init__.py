"""mechfmu: mechanism models as FMI 2.0 co-simulation FMUs.

``mechfmu.runtime`` is what every FMU carries (standard library only); everything else is
host side.
"""

__version__ = "0.1.0"
