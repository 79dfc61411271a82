"""Which components of a result can be drawn: their model and their geometry columns.

A component is drawn from the outputs of its model's ``geometry`` effect
(mechfmu.runtime.fmi.geometry), recorded as ``component.<point>_x`` / ``_y`` columns. Its
model is the one the result's metadata names (``attrs["components"][name]["model"]``, as
mechfmu.simulate, mechfmu run and read_result give it), or else the mechanism model whose
geometry outputs the component's columns hold.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas

from ...runtime.fmi.geometry import GEOMETRY, is_geometry
from ...runtime.models import MODELS
from ..docs import model_class

HOW_TO = (
    f"switch the {GEOMETRY!r} effect on and record its outputs: `mechfmu run SCENE "
    f"--animate`, `mechfmu.simulate(scene, geometry=True)`, or effects = [{GEOMETRY!r}] "
    f"in the scene's component (and its outputs in `record`)"
)


class AnimationError(ValueError):
    """A result that cannot be animated, or options that cannot be used; the message says
    what is missing and how to get it."""


def geometry_outputs(model: str) -> tuple[str, ...]:
    """The names of the geometry effect's outputs of ``model`` (() for a model without it)."""
    if model not in MODELS:
        return ()
    return tuple(v.name for v in model_class(model).VARIABLES if is_geometry(v))


MECHANISMS = tuple(name for name in MODELS if geometry_outputs(name))


@dataclass
class DrawnComponent:
    """One component of a result, to be drawn: its name, model, geometry columns (name
    without the component prefix -> values over the result's rows, m or rad) and the
    parameters its metadata records (empty without metadata)."""

    name: str
    model: str
    columns: dict[str, np.ndarray]
    parameters: dict[str, Any] = field(default_factory=dict)

    def point(self, name: str) -> np.ndarray:
        """The (rows, 2) positions (m) of geometry point ``name``."""
        return np.column_stack([self.columns[f"{name}_x"], self.columns[f"{name}_y"]])


def _component_names(table: pandas.DataFrame) -> dict[str, set[str]]:
    """{component: the variable names it has columns of}."""
    found: dict[str, set[str]] = {}
    for column in table.columns:
        component, dot, variable = str(column).partition(".")
        if dot:
            found.setdefault(component, set()).add(variable)
    return found


def _model_of(name: str, variables: set[str], metadata: dict[str, Any]) -> str | None:
    """The model of component ``name``: its metadata's, or else the mechanism whose every
    geometry output it has (the one with the most of them)."""
    model = metadata.get(name, {}).get("model")
    if model is not None:
        return str(model)
    holding = [m for m in MECHANISMS if set(geometry_outputs(m)) <= variables]
    return max(holding, key=lambda m: len(geometry_outputs(m))) if holding else None


def drawn_components(table: pandas.DataFrame) -> list[DrawnComponent]:
    """The components of ``table`` to draw, in column order. AnimationError naming the
    effect to switch on when none can be drawn: no mechanism, a mechanism whose geometry
    columns are missing, or columns recorded with the effect off (all zero)."""
    metadata = table.attrs.get("components") or {}
    drawn, problems = [], []
    for name, variables in _component_names(table).items():
        model = _model_of(name, variables, metadata)
        needed = geometry_outputs(model) if model is not None else ()
        if model is None or not needed:
            continue
        missing = [v for v in needed if v not in variables]
        if missing:
            problems.append(
                f"{name} ({model}) lacks the column(s) "
                + ", ".join(f"{name}.{v}" for v in missing[:4])
                + (f" and {len(missing) - 4} more" if len(missing) > 4 else "")
            )
            continue
        columns = {v: table[f"{name}.{v}"].to_numpy(dtype=float) for v in needed}
        if not any(np.any(values != 0.0) for values in columns.values()):
            problems.append(f"{name} ({model}): its geometry columns are all 0 (effect off)")
            continue
        parameters = dict(metadata.get(name, {}).get("parameters") or {})
        drawn.append(DrawnComponent(name, model, columns, parameters))
    if drawn:
        return drawn
    if not problems:
        problems.append(
            "no component of a mechanism model (" + ", ".join(MECHANISMS) + ") in its columns"
        )
    raise AnimationError(
        "cannot animate this result: " + "; ".join(problems) + f". To draw it, {HOW_TO}."
    )
