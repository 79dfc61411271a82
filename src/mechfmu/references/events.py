"""scipy ``solve_ivp`` event functions: the attributes it reads, set in one place."""

from collections.abc import Callable
from typing import Any


def ivp_event(
    function: Callable[..., Any], *, terminal: bool = False, direction: float = 0.0
) -> Callable[..., Any]:
    """``function(t, y)`` marked as a ``solve_ivp`` event: ``terminal`` stops the
    integration at its zero, ``direction`` (+1, -1, 0) selects rising, falling or both
    crossings. Returns ``function``."""
    setattr(function, "terminal", terminal)
    setattr(function, "direction", direction)
    return function
