"""A four-stroke cylinder's gas force over its cycle (numpy): the slider_crank_engine scene's
input table, generated here (never typed in).

A deliberately simple, documented model of an ideal spark-ignition cycle on the default
slider-crank (crank 50 mm, connecting rod 150 mm, in line): cycle angle phi = crank angle
modulo 4 pi, 0 at top dead centre at the start of the intake stroke.

    cylinder volume  V = V_c + A (s_TDC - s(phi)),   s the slider position, A = pi D^2 / 4,
                     V_c = A stroke / (r_c - 1)   (compression ratio r_c);
    intake           0 <= phi < pi:        p = p_0;
    compression and  pi <= phi < 3 pi:     p = p_0 (V_BDC / V)^n (1 + (k - 1) x_b(phi)),
    expansion                              x_b the Wiebe burned fraction
                                           1 - exp(-a ((phi - phi_s) / dphi)^3) after the
                                           spark at phi_s (0 before), k the pressure ratio of
                                           the whole heat release at constant volume;
    blow-down        from 3 pi - 30 deg to 3 pi + 10 deg the pressure falls to p_0 along a
                     half cosine; exhaust at p_0.

The gas force on the piston is (p - p_0) A, positive pushing the piston towards the crank
(the slider_force convention of SliderCrank). Units: m, Pa, N, rad, s.
"""

from typing import Any

import numpy as np
from numpy import ndarray

from . import linkages

CRANK, CONNECTING_ROD = 0.05, 0.15  # m: the default slider-crank (runtime DEFAULT_SLIDER_CRANK)
BORE = 0.08  # m
COMPRESSION_RATIO = 9.0
POLYTROPIC_EXPONENT = 1.32
AMBIENT_PRESSURE = 1.0e5  # Pa
PRESSURE_RATIO = 3.5  # of the heat release at constant volume
SPARK = np.radians(350.0)  # cycle angle of the spark (10 deg before the firing TDC)
BURN_ANGLE = np.radians(50.0)  # Wiebe duration
WIEBE_EFFICIENCY = 5.0  # Wiebe's a: 99.3 % burned at the end of BURN_ANGLE
BLOW_DOWN = (np.radians(510.0), np.radians(550.0))  # exhaust valve: pressure back to p_0


def piston_area(bore: float = BORE) -> float:
    """A = pi D^2 / 4 (m^2)."""
    return np.pi * bore * bore / 4.0


def cylinder_volume(
    cycle_angle: Any, crank: float = CRANK, rod: float = CONNECTING_ROD, bore: float = BORE
) -> ndarray:
    """Cylinder volume (m^3) at the cycle angle (rad), the piston at x = s(phi) of an in-line
    slider-crank (linkages.slider_crank), the head beyond top dead centre."""
    angle = np.asarray(cycle_angle, dtype=float)
    slider = linkages.slider_crank(crank, rod, 0.0, 0, angle, 0.0, 0.0)["slider_position"]
    area = piston_area(bore)
    clearance = area * 2.0 * crank / (COMPRESSION_RATIO - 1.0)
    return clearance + area * ((crank + rod) - slider)


def gas_pressure(cycle_angle: Any, crank: float = CRANK, rod: float = CONNECTING_ROD) -> ndarray:
    """Absolute cylinder pressure (Pa) at the cycle angle (rad, any number of cycles)."""
    phi = np.mod(np.asarray(cycle_angle, dtype=float), 4.0 * np.pi)
    volume = cylinder_volume(phi, crank, rod)
    largest = cylinder_volume(np.pi, crank, rod)  # bottom dead centre
    burned = np.where(
        phi > SPARK,
        1.0 - np.exp(-WIEBE_EFFICIENCY * (np.maximum(phi - SPARK, 0.0) / BURN_ANGLE) ** 3),
        0.0,
    )
    closed = AMBIENT_PRESSURE * (largest / volume) ** POLYTROPIC_EXPONENT
    closed = closed * (1.0 + (PRESSURE_RATIO - 1.0) * burned)
    start, end = BLOW_DOWN
    fall = np.clip((phi - start) / (end - start), 0.0, 1.0)
    blend = 0.5 * (1.0 + np.cos(np.pi * fall))  # 1 before the valve opens, 0 after
    pressure = AMBIENT_PRESSURE + (closed - AMBIENT_PRESSURE) * blend
    in_cycle = (phi >= np.pi) & (phi < end)
    return np.where(in_cycle, pressure, AMBIENT_PRESSURE)


def gas_force(cycle_angle: Any) -> ndarray:
    """(p - p_0) A (N), positive pushing the piston towards the crank."""
    return (gas_pressure(cycle_angle) - AMBIENT_PRESSURE) * piston_area()


def gas_force_table(
    crank_speed: float, cycles: int = 1, degrees_per_row: float = 0.5
) -> tuple[ndarray, ndarray]:
    """(times s, gas force N) of ``cycles`` four-stroke cycles at a constant crank speed
    (rad/s) from top dead centre at t = 0, a row every ``degrees_per_row`` of crank angle."""
    rows = int(round(720.0 * cycles / degrees_per_row)) + 1
    angles = np.radians(np.arange(rows) * degrees_per_row)
    return angles / crank_speed, gas_force(angles)
