"""RoadProfile.fmu: road height source (step, bump, sine, table) for the suspension."""

from ..fmi.slave import non_negative, parameter
from ..physics import road
from .table_source import TableSource, table_variables


class RoadProfile(TableSource):
    """Road height (m, positive upward) and its rate (m/s), exact at any time."""

    description = (
        "Road height source for base excitation: step (kerb), one-cosine bump, sine "
        "or piecewise-linear table from a CSV file"
    )
    VARIABLES = (
        parameter(
            "shape", "bump", "Road shape: " + ", ".join(road.ROAD_SHAPES), values=road.ROAD_SHAPES
        ),
        parameter("height", 0.05, "step: height of the kerb; bump: peak height", unit="m"),
        non_negative(
            "duration", 0.1, "bump: length in time (height (1 - cos(2 pi tau)) / 2 over it)", "s"
        ),
        parameter("start_time", 0.0, "Time of the step, or start of the bump or sine", unit="s"),
        parameter("amplitude", 0.01, "sine: amplitude", unit="m"),
        non_negative("frequency", 1.0, "sine: frequency", "Hz"),
        *table_variables(
            "height",
            "m",
            ("road_height", "r: road height under the tyre, positive upward"),
            ("road_rate", "dr/dt: rate of the road height"),
        ),
    )

    def check_shape(self) -> None:
        v = self.values
        road.check_road(
            v["shape"], v["height"], v["duration"], v["start_time"], v["amplitude"], v["frequency"]
        )

    def update(self, time: float, step_size: float) -> None:
        v = self.values
        sample = road.road(
            time,
            v["shape"],
            v["height"],
            v["duration"],
            v["start_time"],
            v["amplitude"],
            v["frequency"],
            self.table,
        )
        v["road_height"], v["road_rate"] = sample.value, sample.rate
