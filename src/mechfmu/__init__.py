"""mechfmu: mechanism models as FMI 2.0 co-simulation FMUs.

This module is shipped inside every FMU: keep it free of imports beyond the standard library.
"""

__version__ = "0.1.0"
