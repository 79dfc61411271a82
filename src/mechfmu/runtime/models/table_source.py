"""Base of the signal sources that can also play a piecewise-linear table from a CSV file."""

from typing import Any

from ..fmi.declarations import Variable
from ..fmi.slave import MechSlave, output, parameter
from ..physics import profiles


def table_variables(
    column: str,
    unit: str,
    signal: tuple[str, str],
    rate: tuple[str, str],
) -> tuple[Variable, Variable, Variable]:
    """The ``table_file`` parameter (a CSV file with columns time (s) and ``column`` in
    ``unit``) and the source's two outputs: ``signal`` and ``rate``, each (name,
    description), in ``unit`` and ``unit``/s."""
    return (
        parameter(
            "table_file", "", f"shape = table: CSV file with columns time (s), {column} ({unit})"
        ),
        output(signal[0], 0.0, signal[1], unit=unit),
        output(rate[0], 0.0, rate[1], unit=f"{unit}/s"),
    )


class TableSource(MechSlave):
    """Reads ``table_file`` at initialisation when ``shape`` is 'table'; keeps it in the state.

    Subclasses validate their own shape parameters in ``check_shape``.
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.table: Any = None  # tuple[list[float], list[float]] (set_up)

    def check_shape(self) -> Any:
        raise NotImplementedError

    def check_parameters(self) -> None:
        self.check_shape()
        if self.values["shape"] == "table":
            self.table = profiles.read_table(self.values["table_file"])

    def internal_state(self) -> Any:
        return {"table": self.table}

    def restore_internal_state(self, state: Any) -> None:
        self.table = state["table"]
