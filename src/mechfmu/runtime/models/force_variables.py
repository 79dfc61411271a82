"""The FMU variables of the ``forces`` effect, declared once for every model that has it.

Parameters per moving link (mass, centre of mass along and across the link, moment of inertia
about the centre of mass), gravity, the external loads as inputs (read only with the effect
on) and the published forces: each joint's force as x, y and magnitude in ground axes, the
driving effort, the input power, the shaking force and moment, the energies.
"""

import math

from ..errors import MechanismError, require_finite
from ..fmi.declarations import Variable, effect, input_, non_negative, only_with, output, parameter
from ..physics.link_forces import MassLayout, gravity_vector, mass_layout

FORCES = "forces"
STANDARD_GRAVITY = 9.80665  # m/s^2
DOWN = -0.5 * math.pi  # rad: gravity along -y


def forces_effect(what: str) -> Variable:
    """The ``forces`` effect parameter; ``what``: what it computes for this model."""
    return effect(FORCES, "Newton-Euler force analysis: " + what)


def only_with_forces(description: str) -> str:
    """Description of an input read only with the forces effect on."""
    return only_with(FORCES, "True", description)


def link_mass_variables(
    link: str, layout: MassLayout, what: str, along: str
) -> tuple[Variable, ...]:
    """``<link>_mass``, ``_com_along``, ``_com_across`` and ``_inertia`` of one moving link
    (``what``: its name in descriptions; ``along``: the direction its x axis runs), starting
    at ``layout``."""
    return (
        non_negative(f"{link}_mass", layout.mass, f"forces: mass of the {what}", "kg"),
        parameter(
            f"{link}_com_along",
            layout.com_x,
            f"forces: centre of mass of the {what}, distance along {along}",
            unit="m",
        ),
        parameter(
            f"{link}_com_across",
            layout.com_y,
            f"forces: centre of mass of the {what}, distance to the left of {along}",
            unit="m",
        ),
        non_negative(
            f"{link}_inertia",
            layout.inertia,
            f"forces: moment of inertia of the {what} about its centre of mass",
            "kg.m2",
        ),
    )


def link_layout(values: dict, link: str) -> MassLayout:
    """The validated MassLayout of ``link`` from the model's values (RangeError names a
    negative mass or inertia)."""
    return mass_layout(
        link,
        values[f"{link}_mass"],
        values[f"{link}_com_along"],
        values[f"{link}_com_across"],
        values[f"{link}_inertia"],
    )


def gravity_variables() -> tuple[Variable, ...]:
    """The ``gravity`` effect (weight of the links in the force analysis), its magnitude and
    direction."""
    return (
        effect("gravity", "weight of the links in the force analysis (needs forces)"),
        non_negative("gravity_acceleration", STANDARD_GRAVITY, "forces, gravity: g", "m/s2"),
        parameter(
            "gravity_direction",
            DOWN,
            "forces, gravity: direction of gravity, angle from +x (-pi/2: along -y)",
            unit="rad",
        ),
    )


def coupler_point_variables(along: float, across: float, link: str) -> tuple[Variable, ...]:
    """The coupler point's position on ``link`` (parameters) and the force applied there
    (inputs, ground axes)."""
    return (
        parameter(
            "coupler_point_along",
            along,
            f"forces: coupler point P, distance along {link}",
            unit="m",
        ),
        parameter(
            "coupler_point_across",
            across,
            f"forces: coupler point P, distance to the left of {link}",
            unit="m",
        ),
        input_(
            "coupler_force_x", 0.0, only_with_forces("external force at P, x (ground axes)"), "N"
        ),
        input_(
            "coupler_force_y", 0.0, only_with_forces("external force at P, y (ground axes)"), "N"
        ),
    )


def joint_force_outputs(joint: str, description: str, depends: tuple[str, ...]) -> tuple:
    """``<joint>_force_x``, ``_y`` and ``_magnitude`` (N, ground axes): ``description`` says
    which link exerts it on which."""
    return (
        output(f"{joint}_force_x", 0.0, f"forces: {description}, x", unit="N", depends=depends),
        output(f"{joint}_force_y", 0.0, f"forces: {description}, y", unit="N", depends=depends),
        output(
            f"{joint}_force_magnitude",
            0.0,
            f"forces: {description}, magnitude",
            unit="N",
            depends=depends,
            min=0.0,
        ),
    )


def shaking_outputs(about: str, depends: tuple[str, ...]) -> tuple[Variable, ...]:
    """Shaking force (x, y, magnitude) and moment (about ``about``), and the kinetic and
    potential energy of the moving links."""
    return (
        *joint_force_outputs(
            "shaking",
            "shaking force on the frame, -sum m a_G of the moving links",
            depends,
        ),
        output(
            "shaking_moment",
            0.0,
            f"forces: shaking moment on the frame about {about}, -sum (I_G alpha + r_G x m a_G)",
            unit="N.m",
            depends=depends,
        ),
        output(
            "kinetic_energy",
            0.0,
            "forces: kinetic energy of the moving links",
            unit="J",
            depends=depends,
        ),
        output(
            "potential_energy",
            0.0,
            "forces, gravity: potential energy of the moving links, -sum m g . r_G",
            unit="J",
            depends=depends[:1],
        ),
    )


def coupler_point_outputs(depends: tuple[str, ...]) -> tuple[Variable, ...]:
    """The coupler point's position (m, ground axes): its path over a cycle."""
    return (
        output("coupler_point_x", 0.0, "forces: coupler point P, x", unit="m", depends=depends),
        output("coupler_point_y", 0.0, "forces: coupler point P, y", unit="m", depends=depends),
    )


def crank_drive_outputs(depends: tuple[str, ...]) -> tuple[Variable, ...]:
    """The crank torque (Norton's T12) and the input power."""
    return (
        output(
            "crank_torque",
            0.0,
            "forces: driving torque on the crank, T12 (counter-clockwise)",
            unit="N.m",
            depends=depends,
        ),
        output(
            "input_power",
            0.0,
            "forces: instantaneous input power, crank_torque * crank_speed",
            unit="W",
            depends=depends,
        ),
    )


def gravity_setting(values: dict) -> tuple[float, float]:
    """Gravity (m/s^2, ground axes) from the gravity effect and its parameters: (0, 0) when
    off. MechanismError for gravity without the forces effect (it would change nothing).
    The magnitude and direction are checked (RangeError) with the effect off too."""
    vector = gravity_vector(values["gravity_acceleration"], values["gravity_direction"])
    if not values["gravity"]:
        return (0.0, 0.0)
    if not values[FORCES]:
        raise MechanismError(
            "the gravity effect needs the forces effect: gravity acts on the links only in "
            "the force analysis (list both effects, or neither)"
        )
    return vector


def coupler_point(values: dict) -> tuple[float, float]:
    """(along, across) of the coupler point (m), finite."""
    return (
        require_finite("coupler_point_along", values["coupler_point_along"], "m"),
        require_finite("coupler_point_across", values["coupler_point_across"], "m"),
    )


def outputs_of(variables: tuple[Variable, ...]) -> tuple[str, ...]:
    """The names of the outputs among ``variables`` (a model's EFFECT_OUTPUTS entry)."""
    return tuple(v.name for v in variables if v.causality == "output")
