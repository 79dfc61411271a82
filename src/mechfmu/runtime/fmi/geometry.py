"""The ``geometry`` effect: where each joint and body is, as outputs (standard library only).

Every mechanism model declares the effect and its outputs with ``geometry_effect`` and
implements ``geometry_points`` (the output values from its current values, by the pure
functions of physics/joint_positions.py). With the effect on, ``install`` makes each update
(and the outputs at the start) write them after the model's own outputs; with it off the
model's update runs as it is, with no test and no call added, so the step costs what it cost
without the effect.
"""

from typing import Any

from .declarations import Variable, effect, output

GEOMETRY = "geometry"
# How a host tells the geometry outputs from the others in a model description.
GEOMETRY_PREFIX = "Geometry: "


def geometry_output(
    name: str, description: str, unit: str = "m", depends: tuple[str, ...] = ()
) -> Variable:
    """One output of the geometry effect (0 while the effect is off)."""
    return output(name, 0.0, GEOMETRY_PREFIX + description, unit=unit, depends=depends)


def geometry_effect(
    frame: str,
    points: dict[str, str],
    depends: tuple[str, ...] = (),
    extra: tuple[Variable, ...] = (),
) -> tuple[Variable, ...]:
    """The effect's switch and its outputs: ``<point>_x`` and ``<point>_y`` (m) of each of
    ``points`` ({name: what the point is}) in the drawing frame described by ``frame``, then
    ``extra`` (geometry_output of other quantities a drawing needs, such as a cam's angle).
    ``depends``: the inputs that move the points (their FMI dependencies)."""
    coordinates = tuple(
        geometry_output(f"{name}_{axis}", f"{axis} of {text}", depends=depends)
        for name, text in points.items()
        for axis in ("x", "y")
    )
    switch = effect(
        GEOMETRY,
        "joint and body positions for drawing (outputs "
        + ", ".join(f"{name}_x/_y" for name in points)
        + (", " + ", ".join(v.name for v in extra) if extra else "")
        + f"; m, rad) in the frame: {frame}",
    )
    return (switch, *coordinates, *extra)


def is_geometry(variable: Variable) -> bool:
    """Whether ``variable`` is an output of the geometry effect."""
    return variable.causality == "output" and variable.description.startswith(GEOMETRY_PREFIX)


def install(slave: Any) -> None:
    """After ``slave.check_parameters``: with the geometry effect on, make ``slave.update``
    and ``slave.outputs_at_start`` write the geometry outputs (``slave.geometry_points()``,
    a dict) after the model's own; with it off (or no such effect) leave both as the class
    defines them. Called again when the parameters change (initialisation mode)."""
    for name in ("update", "outputs_at_start"):
        slave.__dict__.pop(name, None)  # the class's own methods again
    if not slave.values.get(GEOMETRY):
        return
    model_update, model_start = slave.update, slave.outputs_at_start
    write, points = slave.values.update, slave.geometry_points

    def update(time: float, step_size: float) -> None:
        model_update(time, step_size)
        write(points())

    def outputs_at_start(time: float) -> None:
        model_start(time)
        write(points())

    slave.update, slave.outputs_at_start = update, outputs_at_start
