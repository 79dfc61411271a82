"""CrankDrive.fmu and CamshaftDrive.fmu: shaft angle sources at constant or ramped speed."""

from ..fmi.slave import non_negative, MechSlave, motion_outputs, parameter
from ..physics import profiles
from ..fmi.declarations import Variable


class _ShaftDrive(MechSlave):
    """Angle, speed and acceleration of a shaft, exact at any time (profiles.rotation).

    Subclasses name the outputs (PREFIX) and the shaft's speed ratio to the parameters
    (RATIO): the camshaft turns at half the crankshaft (engine) speed.
    """

    PREFIX = ""
    RATIO = 1.0

    def check_parameters(self) -> None:
        v = self.values
        profiles.check_rotation(v["initial_angle"], v["initial_speed"], v["speed"], v["ramp_time"])

    def update(self, time: float, step_size: float) -> None:
        v = self.values
        sample = profiles.rotation(
            time,
            v["initial_angle"],
            self.RATIO * v["initial_speed"],
            self.RATIO * v["speed"],
            v["ramp_time"],
            v["start_time"],
        )
        prefix = self.PREFIX
        v[prefix + "_angle"], v[prefix + "_speed"], v[prefix + "_acceleration"] = sample


def _variables(prefix: str, shaft: str, speed_description: str) -> tuple[Variable, ...]:
    return (
        parameter("initial_angle", 0.0, f"{shaft} angle at start_time", unit="rad"),
        parameter(
            "initial_speed",
            0.0,
            speed_description + " before and at the start of the ramp",
            unit="rad/s",
        ),
        parameter(
            "speed",
            10.0,
            speed_description + " after the ramp (constant speed: set ramp_time = 0)",
            unit="rad/s",
        ),
        non_negative(
            "ramp_time", 0.0, "Duration of the linear speed ramp (0: constant speed)", "s"
        ),
        parameter("start_time", 0.0, "Time at which the ramp starts", unit="s"),
        *motion_outputs(
            (prefix + "_angle", prefix + "_speed", prefix + "_acceleration"),
            "rad",
            (
                f"{shaft} angle, continuous over revolutions",
                f"{shaft} angular speed",
                f"{shaft} angular acceleration",
            ),
        ),
    )


class CrankDrive(_ShaftDrive):
    """Crank angle source for FourBar and SliderCrank."""

    description = "Crank drive: crank angle, speed and acceleration at constant or ramped speed"
    PREFIX = "crank"
    VARIABLES = _variables("crank", "Crank", "Crank speed")


class CamshaftDrive(_ShaftDrive):
    """Camshaft angle source for ValveTrain; speeds are given for the crankshaft (engine)
    and the camshaft turns at half of them (four-stroke engine: one cycle in two turns)."""

    description = (
        "Camshaft drive: camshaft angle, speed and acceleration at half the given "
        "engine (crankshaft) speed, constant or ramped"
    )
    PREFIX = "camshaft"
    RATIO = 0.5
    VARIABLES = _variables(
        "camshaft", "Camshaft", "Engine (crankshaft) speed; the camshaft turns at half of it,"
    )
