"""HydraulicActuator.fmu: the gear's hydraulic actuator as a component of its own."""

from typing import Any

from ..fmi.integrating import IntegratingSlave
from ..fmi.slave import non_negative, input_, integrator_variables, output
from ..physics import hydraulics
from ..errors import require_finite
from ..physics.landing_gear import COURSEWORK_EXTENDED_LENGTH, COURSEWORK_RETRACTED_LENGTH

# The actuator's parameters, declared once: LandingGear's hydraulics effect uses them too.
HYDRAULIC_PARAMETERS = (
    non_negative("supply_pressure", hydraulics.DEFAULT_SUPPLY_PRESSURE, "Supply pressure", "Pa"),
    non_negative("return_pressure", hydraulics.DEFAULT_RETURN_PRESSURE, "Return pressure", "Pa"),
    non_negative("bore", hydraulics.DEFAULT_BORE, "Piston bore", "m"),
    non_negative("rod_diameter", hydraulics.DEFAULT_ROD, "Piston rod diameter", "m"),
    non_negative("bulk_modulus", hydraulics.DEFAULT_BULK_MODULUS, "Effective bulk modulus", "Pa"),
    non_negative(
        "dead_volume",
        hydraulics.DEFAULT_DEAD_VOLUME,
        "Fluid volume of each chamber and its line at the end of the stroke",
        "m3",
    ),
    non_negative(
        "valve_rated_flow",
        hydraulics.DEFAULT_RATED_FLOW,
        "Flow through a fully open valve edge at the rated pressure drop",
        "m3/s",
    ),
    non_negative(
        "valve_rated_pressure_drop",
        hydraulics.DEFAULT_RATED_PRESSURE_DROP,
        "Pressure drop at which valve_rated_flow is rated",
        "Pa",
    ),
    non_negative("max_flow", hydraulics.DEFAULT_MAX_FLOW, "Flow limit of each line", "m3/s"),
)


class HydraulicActuator(IntegratingSlave):
    """Chamber pressures integrated from valve flows and piston motion; force out.

    The force depends only on the pressures (states), not directly on the inputs, so a scene
    can close the loop gear -> actuator -> gear without an algebraic loop.
    """

    description = (
        "Double-acting hydraulic actuator with a 4-way valve, flow limit and fluid "
        "compressibility: valve command and piston motion in, piston force out"
    )
    VARIABLES = (
        *HYDRAULIC_PARAMETERS,
        non_negative("stroke_min", COURSEWORK_RETRACTED_LENGTH, "Shortest piston length", "m"),
        non_negative("stroke_max", COURSEWORK_EXTENDED_LENGTH, "Longest piston length", "m"),
        non_negative(
            "initial_pressure",
            hydraulics.DEFAULT_RETURN_PRESSURE,
            "Pressure in both chambers at the start",
            "Pa",
        ),
        *integrator_variables(default="radau", rtol=1e-8, atol=1.0),
        input_(
            "valve_command",
            0.0,
            "Valve opening in [-1, 1], positive extends the piston",
            unit="1",
            min=-1.0,
            max=1.0,
        ),
        input_("piston_extension", COURSEWORK_RETRACTED_LENGTH, "Piston length", unit="m", min=0.0),
        input_("piston_speed", 0.0, "Piston length rate", unit="m/s"),
        output("piston_force", 0.0, "p_cap A_cap - p_rod A_rod, positive extending", unit="N"),
        output("cap_pressure", 0.0, "Cap-side chamber pressure", unit="Pa"),
        output("rod_pressure", 0.0, "Rod-side chamber pressure", unit="Pa"),
        output("cap_flow", 0.0, "Flow into the cap side", unit="m3/s", depends=("valve_command",)),
        output(
            "rod_flow", 0.0, "Flow out of the rod side", unit="m3/s", depends=("valve_command",)
        ),
    )

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.actuator: Any = None  # hydraulics.Actuator (set_up)

    # IntegratingSlave: the state is the cap and rod pressures (Pa).
    def set_up(self) -> bool:
        v = self.values
        self.actuator = hydraulics.make_actuator(
            v["supply_pressure"],
            v["return_pressure"],
            v["bore"],
            v["rod_diameter"],
            v["bulk_modulus"],
            v["dead_volume"],
            v["valve_rated_flow"],
            v["valve_rated_pressure_drop"],
            v["max_flow"],
            v["stroke_min"],
            v["stroke_max"],
        )
        require_finite("initial_pressure", v["initial_pressure"], "Pa")
        return True

    def initial_state(self, time: float) -> Any:
        pressure = self.values["initial_pressure"]
        return [pressure, pressure]

    def advance(self, start: float, time: float, inputs: Any) -> Any:
        v = self.values
        command = require_finite("valve_command", v["valve_command"])
        length = require_finite("piston_extension", v["piston_extension"], "m")
        speed = require_finite("piston_speed", v["piston_speed"], "m/s")

        def rhs(t: float, y: Any):
            return list(
                hydraulics.pressure_rates(command, y[0], y[1], length, speed, self.actuator)
            )

        return self.integrator.advance(rhs, start, self.state, time).y, None

    def publish(self, time: float) -> None:
        v = self.values
        p1, p2 = self.state
        v["cap_pressure"], v["rod_pressure"] = p1, p2
        v["piston_force"] = hydraulics.piston_force(p1, p2, self.actuator)
        flows = hydraulics.valve_flows(v["valve_command"], p1, p2, self.actuator)
        v["cap_flow"], v["rod_flow"] = flows.cap, flows.rod
