"""Force references for the four-bar and the slider-crank (numpy), by routes of their own.

The runtime (runtime/physics/link_forces.py) assembles the transposed constraint Jacobian of
any mechanism from its joints and solves it with the constraint solver's LU kernels. Here:

1. Norton's matrix, written out link by link (Design of Machinery, sect. 11.4 for the
   four-bar, 11.6 for the slider-crank, re-derived here in our sign conventions): the three
   Newton-Euler equations of each link about its own centre of mass, the pin forces and the
   crank torque as unknowns, one dense system per sample, np.linalg.solve on the stack. It
   gives every published force column of the scene references.
2. The power balance, from the kinematics alone (no force anywhere): the crank's input power
   equals d(KE)/dt + d(PE)/dt minus the power of the external loads, every rate taken from
   the links' velocities and accelerations, T12 omega2 = sum(m v_G . a_G + I_G omega alpha)
   - sum(m g . v_G) - P_loads.
3. Virtual work at rest: with no speed and no acceleration, T12 = -sum F . dr/dtheta2 over
   the weights and the loads, the derivatives by central differences of positions alone.
4. The slider-crank's shaking force by the classic lumped-mass model and the first two
   harmonics of the piston acceleration (Norton, sect. 13.3-13.5): primary and secondary.

Mass layouts are (mass kg, centre of mass along the link m, across it m, inertia about the
centre of mass kg m^2), each link's axis as in the runtime: crank O2 -> A, coupler A -> B,
rocker O4 -> B; the slider a point mass at B. Angles in rad, SI units throughout.
"""

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from numpy import ndarray

from . import linkages

Layout = Sequence[float]  # (mass, com_along, com_across, inertia)


def _rotate(angle: ndarray, x: float, y: float) -> tuple[ndarray, ndarray]:
    c, s = np.cos(angle), np.sin(angle)
    return c * x - s * y, s * x + c * y


def _cross(ax: Any, ay: Any, bx: Any, by: Any) -> Any:
    return ax * by - ay * bx


class Link:
    """One link's pose over time: its frame origin (m), angle (rad) and their rates."""

    def __init__(
        self,
        origin: tuple[ndarray, ndarray],
        velocity: tuple[ndarray, ndarray],
        acceleration: tuple[ndarray, ndarray],
        angle: ndarray,
        omega: ndarray,
        alpha: ndarray,
    ) -> None:
        self.origin, self.velocity, self.acceleration = origin, velocity, acceleration
        self.angle, self.omega, self.alpha = angle, omega, alpha

    def point(self, x: float, y: float) -> tuple[ndarray, ndarray]:
        """Position of the body-frame point (x, y)."""
        px, py = _rotate(self.angle, x, y)
        return self.origin[0] + px, self.origin[1] + py

    def point_velocity(self, x: float, y: float) -> tuple[ndarray, ndarray]:
        px, py = _rotate(self.angle, x, y)
        return self.velocity[0] - self.omega * py, self.velocity[1] + self.omega * px

    def point_acceleration(self, x: float, y: float) -> tuple[ndarray, ndarray]:
        px, py = _rotate(self.angle, x, y)
        w2, al = self.omega**2, self.alpha
        return (
            self.acceleration[0] - al * py - w2 * px,
            self.acceleration[1] + al * px - w2 * py,
        )


def _pin(length: float, angle: ndarray, omega: ndarray, alpha: ndarray) -> tuple:
    """Position, velocity, acceleration of the end of a link of ``length`` turning about
    the origin."""
    c, s = np.cos(angle), np.sin(angle)
    return (
        (length * c, length * s),
        (-length * omega * s, length * omega * c),
        (-length * alpha * s - length * omega**2 * c, length * alpha * c - length * omega**2 * s),
    )


def _crank_and_coupler(
    crank_length: float, crank: Sequence[Any], motion: Mapping[str, Any]
) -> tuple[ndarray, list[Link]]:
    """(zeros shaped like the samples, [crank, coupler]) of both linkages: the crank about the
    origin, the coupler's frame at the crank pin."""
    t2, w2, al2 = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in crank))
    zero = np.zeros_like(t2)
    pin, velocity, acceleration = _pin(crank_length, t2, w2, al2)
    return zero, [
        Link((zero, zero), (zero, zero), (zero, zero), t2, w2, al2),
        Link(
            pin,
            velocity,
            acceleration,
            motion["coupler_angle"],
            motion["coupler_angular_velocity"],
            motion["coupler_angular_acceleration"],
        ),
    ]


def four_bar_links(
    lengths: Sequence[float], crank: Sequence[Any], motion: Mapping[str, Any]
) -> list[Link]:
    """Crank, coupler and rocker poses from the crank (angle, speed, acceleration) and the
    coupler and rocker motion (linkages.four_bar's columns). ``lengths``: ground, crank,
    coupler, rocker (m)."""
    zero, links = _crank_and_coupler(lengths[1], crank, motion)
    rocker = Link(
        (zero + lengths[0], zero),
        (zero, zero),
        (zero, zero),
        motion["rocker_angle"],
        motion["rocker_angular_velocity"],
        motion["rocker_angular_acceleration"],
    )
    return [*links, rocker]


def slider_crank_links(
    geometry: Sequence[float], crank: Sequence[Any], motion: Mapping[str, Any]
) -> list[Link]:
    """Crank, connecting rod and slider poses from the crank motion and the slider-crank's
    columns (linkages.slider_crank's). ``geometry``: crank, coupler, offset (m)."""
    zero, links = _crank_and_coupler(geometry[0], crank, motion)
    slider = Link(
        (motion["slider_position"], zero + geometry[2]),
        (motion["slider_speed"], zero),
        (motion["slider_acceleration"], zero),
        zero,
        zero,
        zero,
    )
    return [*links, slider]


def energies(
    links: Sequence[Link], layouts: Sequence[Layout], gravity: tuple[float, float]
) -> dict[str, ndarray]:
    """kinetic_energy, potential_energy (J) and their rates (W), and the shaking force
    (N) and moment (N m, about the ground origin), from the links' motion alone."""
    kinetic: Any = 0.0
    potential: Any = 0.0
    kinetic_rate: Any = 0.0
    potential_rate: Any = 0.0
    force_x: Any = 0.0
    force_y: Any = 0.0
    moment: Any = 0.0
    for link, (m, cx, cy, inertia) in zip(links, layouts):
        gx, gy = link.point(cx, cy)
        vx, vy = link.point_velocity(cx, cy)
        ax, ay = link.point_acceleration(cx, cy)
        kinetic = kinetic + 0.5 * (m * (vx * vx + vy * vy) + inertia * link.omega**2)
        kinetic_rate = kinetic_rate + m * (vx * ax + vy * ay) + inertia * link.omega * link.alpha
        potential = potential - m * (gravity[0] * gx + gravity[1] * gy)
        potential_rate = potential_rate - m * (gravity[0] * vx + gravity[1] * vy)
        force_x = force_x - m * ax
        force_y = force_y - m * ay
        moment = moment - (inertia * link.alpha + m * _cross(gx, gy, ax, ay))
    return {
        "kinetic_energy": kinetic,
        "potential_energy": potential,
        "kinetic_energy_rate": kinetic_rate,
        "potential_energy_rate": potential_rate,
        "shaking_force_x": force_x,
        "shaking_force_y": force_y,
        "shaking_force_magnitude": np.hypot(force_x, force_y),
        "shaking_moment": moment,
    }


def load_power(
    links: Sequence[Link],
    coupler_point: tuple[float, float],
    coupler_force: tuple[Any, Any],
    output_torque: Any = 0.0,
    slider_force_x: Any = 0.0,
) -> Any:
    """Power (W) of the external loads: the force at the coupler point, a torque on the
    third link (the rocker) and a force along x on it (the slider)."""
    vx, vy = links[1].point_velocity(*coupler_point)
    return (
        coupler_force[0] * vx
        + coupler_force[1] * vy
        + output_torque * links[2].omega
        + slider_force_x * links[2].velocity[0]
    )


def power_balance_torque(
    links: Sequence[Link],
    layouts: Sequence[Layout],
    gravity: tuple[float, float],
    loads_power: Any,
) -> dict[str, ndarray]:
    """input_power = dKE/dt + dPE/dt - P_loads (W), and crank_torque = input_power /
    crank speed where the crank turns (NaN where it does not)."""
    rates = energies(links, layouts, gravity)
    power = rates["kinetic_energy_rate"] + rates["potential_energy_rate"] - loads_power
    omega = links[0].omega
    with np.errstate(invalid="ignore", divide="ignore"):
        torque = np.where(omega != 0.0, power / np.where(omega != 0.0, omega, 1.0), np.nan)
    return {"input_power": power, "crank_torque": torque}


def _solve_rows(rows: list[list[Any]], rhs: list[Any], size: int) -> ndarray:
    """Solve the stacked systems given as rows of (broadcastable) coefficient arrays."""
    count = np.broadcast_shapes(*(np.shape(c) for row in rows for c in row), *map(np.shape, rhs))
    matrix = np.zeros(count + (size, size))
    for i, row in enumerate(rows):
        for j, coefficient in enumerate(row):
            matrix[..., i, j] = coefficient
    vector = np.stack([np.broadcast_to(np.asarray(v, dtype=float), count) for v in rhs], axis=-1)
    return np.linalg.solve(matrix, vector[..., None])[..., 0]


def _link_terms(
    link: Link, layout: Layout, gravity: tuple[float, float]
) -> tuple[tuple[ndarray, ndarray], tuple[ndarray, ndarray], ndarray]:
    """(centre of mass, m a_G - m g, I_G alpha) of one link."""
    m, cx, cy, inertia = layout
    ax, ay = link.point_acceleration(cx, cy)
    return (
        link.point(cx, cy),
        (m * ax - m * gravity[0], m * ay - m * gravity[1]),
        inertia * link.alpha,
    )


def _arm(point: Any, centre: Any) -> tuple[Any, Any]:
    """The vector from ``centre`` to ``point`` (m)."""
    return point[0] - centre[0], point[1] - centre[1]


def _crank_and_coupler_rows(size: int, r12: Any, r32: Any, r23: Any, r43: Any) -> list[list[Any]]:
    """The six rows of the crank's and the coupler's Newton-Euler equations in the unknowns
    (F12x, F12y, F32x, F32y, F43x, F43y, ..., T12 last) of a system of ``size``: sum F and
    sum of moments about G (r x F = rx Fy - ry Fx), F23 = -F32."""

    def row(*head: Any, torque: float = 0.0) -> list[Any]:
        return [*head, *([0.0] * (size - 1 - len(head))), torque]

    return [
        row(1.0, 0.0, 1.0, 0.0),
        row(0.0, 1.0, 0.0, 1.0),
        row(-r12[1], r12[0], -r32[1], r32[0], torque=1.0),
        row(0.0, 0.0, -1.0, 0.0, 1.0, 0.0),
        row(0.0, 0.0, 0.0, -1.0, 0.0, 1.0),
        row(0.0, 0.0, r23[1], -r23[0], -r43[1], r43[0]),
    ]


def _crank_and_coupler_rhs(f2: Any, i2: Any, f3: Any, i3: Any, rp: Any, force: Any) -> list[Any]:
    """The right-hand sides of _crank_and_coupler_rows: m a_G - m g and I_G alpha of crank
    and coupler, less the force at the coupler point P and its moment (``rp``: G3 -> P)."""
    fpx, fpy = force
    return [f2[0], f2[1], i2, f3[0] - fpx, f3[1] - fpy, i3 - _cross(rp[0], rp[1], fpx, fpy)]


def _forces(prefix: str, fx: ndarray, fy: ndarray) -> dict[str, ndarray]:
    return {f"{prefix}_x": fx, f"{prefix}_y": fy, f"{prefix}_magnitude": np.hypot(fx, fy)}


def norton_four_bar(
    lengths: Sequence[float],
    links: Sequence[Link],
    layouts: Sequence[Layout],
    gravity: tuple[float, float],
    coupler_point: tuple[float, float],
    coupler_force: tuple[Any, Any] = (0.0, 0.0),
    rocker_torque: Any = 0.0,
) -> dict[str, ndarray]:
    """Pin forces and crank torque of the four-bar by Norton's 9 x 9 matrix.

    Unknowns x = (F12x, F12y, F32x, F32y, F43x, F43y, F14x, F14y, T12), F_ij the force of
    link i on link j; rows: for the crank, coupler and rocker in turn, sum F = m a_G - m g
    and sum of moments about G = I_G alpha, with F23 = -F32 and F34 = -F43. ``lengths``:
    ground, crank, coupler, rocker (m)."""
    crank, coupler, rocker = links
    o2 = (0.0, 0.0)
    pin_a = crank.point(lengths[1], 0.0)
    pin_b = coupler.point(lengths[2], 0.0)
    o4 = rocker.origin
    (g2, f2, i2), (g3, f3, i3), (g4, f4, i4) = (
        _link_terms(link, layout, gravity) for link, layout in zip(links, layouts)
    )
    p = coupler.point(*coupler_point)
    r34, r14, rp = _arm(pin_b, g4), _arm(o4, g4), _arm(p, g3)
    rows = _crank_and_coupler_rows(
        9, _arm(o2, g2), _arm(pin_a, g2), _arm(pin_a, g3), _arm(pin_b, g3)
    )
    rows += [
        [0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 0.0, r34[1], -r34[0], -r14[1], r14[0], 0.0],
    ]
    rhs = _crank_and_coupler_rhs(f2, i2, f3, i3, rp, coupler_force)
    rhs += [f4[0], f4[1], i4 - rocker_torque]
    x = _solve_rows(rows, rhs, 9)
    columns = {
        **_forces("crank_pivot_force", x[..., 0], x[..., 1]),
        **_forces("crank_pin_force", x[..., 2], x[..., 3]),
        **_forces("rocker_pin_force", x[..., 4], x[..., 5]),
        **_forces("rocker_pivot_force", x[..., 6], x[..., 7]),
        "crank_torque": x[..., 8],
        "input_power": x[..., 8] * crank.omega,
        "coupler_point_x": p[0],
        "coupler_point_y": p[1],
    }
    return columns


def norton_slider_crank(
    links: Sequence[Link],
    layouts: Sequence[Layout],
    gravity: tuple[float, float],
    coupler_point: tuple[float, float],
    crank_length: float,
    coupler_length: float,
    coupler_force: tuple[Any, Any] = (0.0, 0.0),
    slider_force_x: Any = 0.0,
    counterweight: tuple[float, float] = (0.0, 0.0),
) -> dict[str, ndarray]:
    """Pin forces, guide force and crank torque of the slider-crank by an 8 x 8 matrix.

    Unknowns x = (F12x, F12y, F32x, F32y, F43x, F43y, F14y, T12); rows: crank and rod as in
    the four-bar, the slider (a point mass at B on a frictionless guide along x) by its two
    force equations. ``slider_force_x``: the external force on the slider along +x (N).
    ``counterweight``: (mass kg, radius m) of a point mass on the crank opposite the pin,
    carried as a part of its own: its m a - m g joins the crank's force rows and its moment
    about the crank's centre of mass the moment row."""
    crank, rod, slider = links
    o2 = (0.0, 0.0)
    pin_a = crank.point(crank_length, 0.0)
    pin_b = rod.point(coupler_length, 0.0)
    (g2, f2, i2), (g3, f3, i3), (_, f4, _) = (
        _link_terms(link, layout, gravity) for link, layout in zip(links, layouts)
    )
    mass_cw, radius_cw = counterweight
    if mass_cw:
        gc, fc, _ = _link_terms(crank, (mass_cw, -radius_cw, 0.0, 0.0), gravity)
        i2 = i2 + _cross(gc[0] - g2[0], gc[1] - g2[1], fc[0], fc[1])
        f2 = (f2[0] + fc[0], f2[1] + fc[1])
    p = rod.point(*coupler_point)
    rp = _arm(p, g3)
    rows = _crank_and_coupler_rows(
        8, _arm(o2, g2), _arm(pin_a, g2), _arm(pin_a, g3), _arm(pin_b, g3)
    )
    rows += [
        [0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 0.0, 0.0, -1.0, 1.0, 0.0],
    ]
    rhs = _crank_and_coupler_rhs(f2, i2, f3, i3, rp, coupler_force)
    rhs += [f4[0] - slider_force_x, f4[1]]
    x = _solve_rows(rows, rhs, 8)
    zeros = np.zeros_like(x[..., 6])
    return {
        **_forces("crank_pivot_force", x[..., 0], x[..., 1]),
        **_forces("crank_pin_force", x[..., 2], x[..., 3]),
        **_forces("slider_pin_force", x[..., 4], x[..., 5]),
        **_forces("guide_force", zeros, x[..., 6]),
        "crank_torque": x[..., 7],
        "input_power": x[..., 7] * crank.omega,
        "coupler_point_x": p[0],
        "coupler_point_y": p[1],
    }


def four_bar_positions(lengths: Sequence[float], circuit: int) -> Callable[[Any], list[Link]]:
    """A function of crank angles returning the links at rest there (for virtual work)."""

    def at(angle: Any) -> list[Link]:
        angle = np.asarray(angle, dtype=float)
        zero = np.zeros_like(angle)
        motion = linkages.four_bar(
            lengths[0], lengths[1], lengths[2], lengths[3], circuit, angle, 0.0, 0.0
        )
        return four_bar_links(lengths, (angle, zero, zero), motion)

    return at


def slider_crank_positions(geometry: Sequence[float], circuit: int) -> Callable[[Any], list[Link]]:
    """A function of crank angles returning the slider-crank's links at rest there."""

    def at(angle: Any) -> list[Link]:
        angle = np.asarray(angle, dtype=float)
        zero = np.zeros_like(angle)
        motion = linkages.slider_crank(
            geometry[0], geometry[1], geometry[2], circuit, angle, 0.0, 0.0
        )
        return slider_crank_links(geometry, (angle, zero, zero), motion)

    return at


def virtual_work_torque(
    positions: Callable[[Any], list[Link]],
    crank_angle: Any,
    layouts: Sequence[Layout],
    gravity: tuple[float, float],
    coupler_point: tuple[float, float],
    coupler_force: tuple[float, float] = (0.0, 0.0),
    output_torque: float = 0.0,
    slider_force_x: float = 0.0,
    step: float = 1e-5,
) -> Any:
    """Crank torque (N m) holding the linkage at rest at ``crank_angle`` against the weights
    and loads, by virtual work: T12 = -d/dtheta2 (sum of load work), the derivatives of the
    positions by a fourth-order central difference of step ``step`` (rad). ``positions``:
    four_bar_positions or slider_crank_positions."""
    angle = np.asarray(crank_angle, dtype=float)

    rest = positions(angle)

    def work(links: list[Link]) -> Any:
        """Work of the weights and loads from the position at rest to ``links``."""
        total = 0.0
        for link, start, (m, cx, cy, _) in zip(links, rest, layouts):
            gx, gy = link.point(cx, cy)
            hx, hy = start.point(cx, cy)
            total = total + m * (gravity[0] * (gx - hx) + gravity[1] * (gy - hy))
        px, py = links[1].point(*coupler_point)
        qx, qy = rest[1].point(*coupler_point)
        total = total + coupler_force[0] * (px - qx) + coupler_force[1] * (py - qy)
        # the rocker angle is wrapped to (-pi, pi]: its change, wrapped again
        turn = np.remainder(links[2].angle - rest[2].angle + np.pi, 2.0 * np.pi) - np.pi
        return (
            total + output_torque * turn + slider_force_x * (links[2].origin[0] - rest[2].origin[0])
        )

    def potential(offset: float) -> Any:
        return work(positions(angle + offset))

    derivative = (
        -potential(2 * step) + 8 * potential(step) - 8 * potential(-step) + potential(-2 * step)
    ) / (12 * step)
    return -derivative


def lumped_shaking_force(
    crank: float,
    coupler: float,
    layouts: Sequence[Layout],
    counterweight: tuple[float, float],
    crank_angle: Any,
    crank_speed: float,
) -> dict[str, ndarray]:
    """The classic approximation of an in-line slider-crank's shaking force at constant crank
    speed (Norton sect. 13.3-13.5): the connecting rod lumped into m3a at the crank pin and
    m3b at the piston pin (same mass and centre of mass), the crank's mass and counterweight
    into m2a at the crank pin, the piston acceleration cut after its second harmonic,

        a_B = -r w^2 (cos wt + (r/l) cos 2wt),
        F_s,x = (m_A + m_B) r w^2 cos wt + m_B r w^2 (r/l) cos 2wt,  F_s,y = m_A r w^2 sin wt,

    with m_A = m2a + m3a (rotating), m_B = m3b + m4 (reciprocating). Returns primary and
    secondary x parts, the y part and their sums (N). ``counterweight``: (mass kg, radius
    m) opposite the pin."""
    r, length, w = crank, coupler, crank_speed
    m2, c2 = layouts[0][0], layouts[0][1]
    m3, c3 = layouts[1][0], layouts[1][1]
    m4 = layouts[2][0]
    mass_cw, radius_cw = counterweight
    m2a = (m2 * c2 - mass_cw * radius_cw) / r  # crank and counterweight, to the pin
    m3a = m3 * (length - c3) / length
    m3b = m3 * c3 / length
    m_a, m_b = m2a + m3a, m3b + m4
    wt = np.asarray(crank_angle, dtype=float)
    primary = (m_a + m_b) * r * w * w * np.cos(wt)
    secondary = m_b * r * w * w * (r / length) * np.cos(2.0 * wt)
    y = m_a * r * w * w * np.sin(wt)
    return {
        "primary_x": primary,
        "secondary_x": secondary,
        "shaking_force_x": primary + secondary,
        "shaking_force_y": y,
    }
