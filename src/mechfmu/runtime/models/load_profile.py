"""LoadProfile.fmu: constant, step, ramp or table-from-CSV load source."""

from ..fmi.slave import non_negative, parameter
from ..physics import profiles
from .table_source import TableSource, table_variables


class LoadProfile(TableSource):
    """A load signal (N) and its rate (N/s)."""

    description = "Load source: constant, step, ramp or piecewise-linear table from a CSV file"
    VARIABLES = (
        parameter(
            "shape",
            "ramp",
            "Load shape: " + ", ".join(profiles.LOAD_SHAPES),
            values=profiles.LOAD_SHAPES,
        ),
        parameter("initial_value", 0.0, "Load before start_time (constant: the load)", unit="N"),
        parameter("final_value", 1000.0, "Load after the step or at the end of the ramp", unit="N"),
        parameter("start_time", 0.0, "Time of the step or start of the ramp", unit="s"),
        non_negative("duration", 1.0, "Ramp duration", "s"),
        *table_variables(
            "load", "N", ("load", "Load"), ("load_rate", "Rate of change of the load")
        ),
    )

    def check_shape(self) -> None:
        v = self.values
        profiles.check_load(
            v["shape"], v["initial_value"], v["final_value"], v["start_time"], v["duration"]
        )

    def update(self, time: float, step_size: float) -> None:
        v = self.values
        sample = profiles.load(
            time,
            v["shape"],
            v["initial_value"],
            v["final_value"],
            v["start_time"],
            v["duration"],
            self.table,
        )
        v["load"], v["load_rate"] = sample.value, sample.rate
