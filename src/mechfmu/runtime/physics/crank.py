"""What the crank-driven linkages (four_bar, slider_crank) check alike (standard library only)."""

from ..errors import RangeError, require_finite

CIRCUITS = (0, 1)  # the two assembly circuits of a crank-driven linkage


def check_circuit(circuit: float | None, meaning: str) -> int:
    """``circuit`` as int, or RangeError naming it (``meaning``: what 0 and 1 are)."""
    if isinstance(circuit, bool) or circuit not in CIRCUITS:
        raise RangeError("circuit", circuit, "{0, 1}", "", meaning)
    return int(circuit)


def crank_drive(angle: float, speed: float, acceleration: float) -> tuple[float, float, float]:
    """The crank's angle (rad), speed (rad/s) and acceleration (rad/s^2) as floats, or
    RangeError naming the first that is not finite."""
    return (
        require_finite("crank_angle", angle, "rad"),
        require_finite("crank_speed", speed, "rad/s"),
        require_finite("crank_acceleration", acceleration, "rad/s^2"),
    )
