"""PistonActuator.fmu: a stroke profile source for the landing gear."""

from ..fmi.slave import MechSlave, motion_outputs, parameter
from ..physics import landing_gear as gear
from ..physics import profiles


class PistonActuator(MechSlave):
    """Piston extension, speed and acceleration, exact for the chosen profile at any time."""

    description = (
        "Piston stroke profile: constant_speed or cycloidal (zero speed and "
        "acceleration at both ends) from start_extension to end_extension"
    )
    VARIABLES = (
        parameter(
            "start_extension",
            gear.COURSEWORK_RETRACTED_LENGTH,
            "Piston length at the start of the stroke",
            unit="m",
        ),
        parameter(
            "end_extension",
            gear.COURSEWORK_EXTENDED_LENGTH,
            "Piston length at the end of the stroke",
            unit="m",
        ),
        parameter(
            "stroke_time",
            gear.COURSEWORK_STROKE_TIME,
            "Duration of the stroke, in (0, 4] s (retraction must take under 4 s)",
            unit="s",
            min=0.0,
            max=profiles.MAX_STROKE_TIME,
        ),
        parameter("start_time", 0.0, "Time at which the stroke starts", unit="s"),
        parameter(
            "profile",
            "constant_speed",
            "Stroke profile: " + ", ".join(profiles.STROKE_PROFILES),
            values=profiles.STROKE_PROFILES,
        ),
        *motion_outputs(
            ("piston_extension", "piston_speed", "piston_acceleration"),
            "m",
            ("Piston length", "Piston length rate", "Piston length second rate"),
        ),
    )

    def _stroke_parameters(self):
        v = self.values
        return (
            v["start_extension"],
            v["end_extension"],
            v["stroke_time"],
            v["profile"],
            v["start_time"],
        )

    def check_parameters(self) -> None:
        profiles.check_stroke(*self._stroke_parameters())

    def update(self, time: float, step_size: float) -> None:
        sample = profiles.stroke(time, *self._stroke_parameters())
        v = self.values
        v["piston_extension"], v["piston_speed"], v["piston_acceleration"] = sample
