"""Base of the signal sources that can also play a piecewise-linear table from a CSV file."""

from typing import Any

from ..fmi.slave import MechSlave
from ..physics import profiles


class TableSource(MechSlave):
    """Reads ``table_file`` at initialisation when ``shape`` is 'table'; keeps it in the state.

    Subclasses validate their own shape parameters in ``check_shape``.
    """

    STEP_CHANGES_STATE = False  # the table is read at initialisation, never in a step

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
