"""The one list of models: FMU name -> module that defines the slave class of that name.

Everything else (build, validation tests, README tables) loops over MODELS.
"""

MODELS = {
    "LandingGear": "mechfmu.runtime.models.landing_gear",
    "HydraulicActuator": "mechfmu.runtime.models.hydraulic_actuator",
    "PistonActuator": "mechfmu.runtime.models.piston_actuator",
    "Suspension": "mechfmu.runtime.models.suspension",
    "LoadProfile": "mechfmu.runtime.models.load_profile",
    "RoadProfile": "mechfmu.runtime.models.road_profile",
    "CrankDrive": "mechfmu.runtime.models.shaft_drives",
    "FourBar": "mechfmu.runtime.models.four_bar",
    "SliderCrank": "mechfmu.runtime.models.slider_crank",
    "CamshaftDrive": "mechfmu.runtime.models.shaft_drives",
    "ValveTrain": "mechfmu.runtime.models.valve_train",
    "ValveSpring": "mechfmu.runtime.models.valve_spring",
}
