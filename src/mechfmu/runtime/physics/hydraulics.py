"""Double-acting hydraulic actuator with a 4-way valve (standard library only).

States: cap-side pressure p1 and rod-side pressure p2 (Pa). The valve command u in [-1, 1]
connects the cap side to supply and the rod side to return for u > 0 (the piston extends),
the reverse for u < 0. Orifice flow follows the square-root law with a small laminar region
(so the flow is smooth through zero pressure drop), and each line passes a flow limiter that
saturates smoothly at max_flow. Fluid compressibility:

    dp1/dt = beta / V1(x) * (Q1 - A1 xdot),   V1 = dead_volume + A1 (x - x_min)
    dp2/dt = beta / V2(x) * (A2 xdot - Q2),   V2 = dead_volume + A2 (x_max - x)

The piston force along the piston (positive extending) is p1 A1 - p2 A2.
Pressures in Pa, flows in m^3/s, lengths in m, forces in N.
"""

from typing import Any
import math
from collections import namedtuple

from ..errors import MechanismError, require_above, require_between, require_positive

# A plausible light-aircraft nose-gear actuator: 3000 psi supply, 25 mm bore, 12 mm rod.
DEFAULT_SUPPLY_PRESSURE = 20.7e6
DEFAULT_RETURN_PRESSURE = 0.3e6
DEFAULT_BORE = 0.025
DEFAULT_ROD = 0.012
DEFAULT_BULK_MODULUS = 1.0e9  # effective, with hose compliance and some entrained air
DEFAULT_DEAD_VOLUME = 2.0e-5
DEFAULT_RATED_FLOW = 1.0e-4  # m^3/s through a fully open valve edge ...
DEFAULT_RATED_PRESSURE_DROP = 7.0e6  # ... at this pressure drop (Pa)
DEFAULT_MAX_FLOW = 5.0e-5  # restrictor: 3 L/min, about 0.1 m/s of cap-side piston speed
LAMINAR_PRESSURE = 1.0e4  # Pa, width of the laminar region around zero pressure drop

Actuator = namedtuple(
    "Actuator",
    "supply_pressure return_pressure cap_area rod_area "
    "bulk_modulus dead_volume flow_coefficient max_flow min_length max_length",
)
Flows = namedtuple("Flows", "cap rod")


def make_actuator(
    supply_pressure: float,
    return_pressure: float,
    bore: float,
    rod: float,
    bulk_modulus: float,
    dead_volume: float,
    rated_flow: float,
    rated_pressure_drop: float,
    max_flow: float,
    min_length: float,
    max_length: float,
) -> "Actuator":
    """Validated Actuator; areas from bore and rod diameters (m); the valve's orifice
    coefficient from its rated flow (m^3/s) at a rated pressure drop (Pa)."""
    supply = require_positive("supply_pressure", supply_pressure, "Pa")
    back = require_between("return_pressure", return_pressure, 0.0, supply, "Pa", high_open=True)
    bore = require_positive("bore", bore, "m")
    rod = require_between("rod_diameter", rod, 0.0, bore, "m", low_open=True, high_open=True)
    require_above("max_length", max_length, min_length, "m", "the stroke must have positive length")
    cap_area = math.pi * bore * bore / 4.0
    return Actuator(
        supply,
        back,
        cap_area,
        cap_area - math.pi * rod * rod / 4.0,
        require_positive("bulk_modulus", bulk_modulus, "Pa"),
        require_positive("dead_volume", dead_volume, "m^3"),
        require_positive("valve_rated_flow", rated_flow, "m^3/s")
        / math.sqrt(require_positive("valve_rated_pressure_drop", rated_pressure_drop, "Pa")),
        require_positive("max_flow", max_flow, "m^3/s"),
        min_length,
        max_length,
    )


def orifice(pressure_drop: float, coefficient: float) -> float:
    """Flow (m^3/s) through an orifice: coefficient * sqrt(|dp|) * sign(dp), smoothed at 0."""
    return coefficient * pressure_drop / math.sqrt(math.hypot(pressure_drop, LAMINAR_PRESSURE))


def limited(flow: float, max_flow: float) -> float:
    """Smooth saturation of a flow at +-max_flow."""
    return max_flow * math.tanh(flow / max_flow)


def valve_flows(
    command: float, cap_pressure: float, rod_pressure: float, actuator: "Actuator"
) -> "Flows":
    """Flows into the cap side and out of the rod side (m^3/s) for a valve command."""
    u = max(-1.0, min(1.0, command))
    a = actuator
    if u >= 0.0:
        into_cap = orifice(a.supply_pressure - cap_pressure, u * a.flow_coefficient)
        out_of_rod = orifice(rod_pressure - a.return_pressure, u * a.flow_coefficient)
    else:
        into_cap = -orifice(cap_pressure - a.return_pressure, -u * a.flow_coefficient)
        out_of_rod = -orifice(a.supply_pressure - rod_pressure, -u * a.flow_coefficient)
    return Flows(limited(into_cap, a.max_flow), limited(out_of_rod, a.max_flow))


def pressure_rates(
    command: Any, cap_pressure: Any, rod_pressure: Any, length: Any, speed: float, actuator: Any
) -> Any:
    """(dp1/dt, dp2/dt) in Pa/s at piston length (m) and speed (m/s)."""
    a = actuator
    flows = valve_flows(command, cap_pressure, rod_pressure, a)
    cap_volume = a.dead_volume + a.cap_area * (length - a.min_length)
    rod_volume = a.dead_volume + a.rod_area * (a.max_length - length)
    if cap_volume <= 0.0 or rod_volume <= 0.0:
        raise MechanismError(
            f"piston length {length!r} m empties a chamber "
            f"(stroke [{a.min_length!r}, {a.max_length!r}] m plus dead volume)"
        )
    return (
        a.bulk_modulus / cap_volume * (flows.cap - a.cap_area * speed),
        a.bulk_modulus / rod_volume * (a.rod_area * speed - flows.rod),
    )


def piston_force(cap_pressure: float, rod_pressure: float, actuator: "Actuator") -> float:
    """Force along the piston, positive extending (N)."""
    return cap_pressure * actuator.cap_area - rod_pressure * actuator.rod_area
