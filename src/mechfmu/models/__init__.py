"""The one list of models: FMU name -> module that defines the slave class of that name.

Everything else (build, validation tests, README tables) loops over MODELS.
"""

MODELS = {
    "LandingGear": "mechfmu.models.landing_gear",
    "HydraulicActuator": "mechfmu.models.hydraulic_actuator",
    "PistonActuator": "mechfmu.models.piston_actuator",
    "Suspension": "mechfmu.models.suspension",
    "LoadProfile": "mechfmu.models.load_profile",
    "RoadProfile": "mechfmu.models.road_profile",
    "CrankDrive": "mechfmu.models.shaft_drives",
    "FourBar": "mechfmu.models.four_bar",
    "SliderCrank": "mechfmu.models.slider_crank",
    "CamshaftDrive": "mechfmu.models.shaft_drives",
    "ValveTrain": "mechfmu.models.valve_train",
    "ValveSpring": "mechfmu.models.valve_spring",
}
