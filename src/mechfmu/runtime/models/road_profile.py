"""RoadProfile.fmu: road height source (step, bump, sine, table) for the suspension."""

from ..fmi.slave import output, parameter
from ..physics import road
from .table_source import TableSource


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
        parameter(
            "duration",
            0.1,
            "bump: length in time (height (1 - cos(2 pi tau)) / 2 over it)",
            unit="s",
            min=0.0,
        ),
        parameter("start_time", 0.0, "Time of the step, or start of the bump or sine", unit="s"),
        parameter("amplitude", 0.01, "sine: amplitude", unit="m"),
        parameter("frequency", 1.0, "sine: frequency", unit="Hz", min=0.0),
        parameter("table_file", "", "shape = table: CSV file with columns time (s), height (m)"),
        output("road_height", 0.0, "r: road height under the tyre, positive upward", unit="m"),
        output("road_rate", 0.0, "dr/dt: rate of the road height", unit="m/s"),
    )

    def check_shape(self) -> None:
        v = self.values
        road.check_road(
            v["shape"], v["height"], v["duration"], v["start_time"], v["amplitude"], v["frequency"]
        )
        # the road's arguments between the time and the table, fixed once initialised
        self.shape = (
            v["shape"],
            v["height"],
            v["duration"],
            v["start_time"],
            v["amplitude"],
            v["frequency"],
        )

    def update(self, time: float, step_size: float) -> None:
        sample = road.road(time, *self.shape, self.table)
        v = self.values
        v["road_height"], v["road_rate"] = sample.value, sample.rate
