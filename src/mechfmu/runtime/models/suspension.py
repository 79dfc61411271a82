"""Suspension.fmu: static (load in, equilibrium out) or dynamic (sprung mass integrated)."""

from ..fmi.geometry import geometry_output, geometry_effect
from ..fmi.integrating import IntegratingSlave
from ..fmi.slave import Status, effect, input_, integrator_variables
from ..fmi.slave import non_negative, output, parameter
from ..physics import joint_positions
from ..physics import suspension as physics
from ..physics import suspension_dynamics as dyn
from ..errors import IntegrationError, MechanismError, SnapThrough, require_finite
from ..numerics.integrators import Event
from ..numerics.stepping import advance_through_events
from ..physics.suspension import Spring
from typing import Any

_INPUTS = ("load", "road_height", "road_rate")
_DYNAMIC_EFFECTS = ("damping", "tyre", "road_input")
# A state whose max-norm exceeds BLOWUP_FACTOR (1 + the initial state's max-norm) is an
# unstable integration (no suspension moves a million metres), refused like the
# integrators' own per-call growth check, which misses a slower growth spread over calls.
BLOWUP_FACTOR = 1e6
# Without road input and under a load constant over the step, T + V cannot grow (the damper
# only dissipates): a gain of more than ENERGY_GROWTH times the energy in play (the sum of
# the terms' magnitudes) within one step is an unstable integration. Accurate methods stay
# below 1e-6 of it; explicit Euler, which gains energy at every sub-step on an undamped
# oscillator, gains (h omega)^2 per sub-step.
ENERGY_GROWTH = 0.5


class Suspension(IntegratingSlave):
    """Two-spring suspension, static or dynamic.

    Static (``dynamics`` off, the default): the equilibrium follows the load continuously from
    the unloaded state (near branch). When the load passes the limit load the near equilibrium
    vanishes: the FMU logs the snap-through, raises the ``snap_through`` flag for that step and
    continues on the far stable branch, or, with ``stop_on_snap_through``, discards the step.

    Dynamic (``dynamics`` on): m y'' = W - F(u) [- c u'] with the optional tyre, unsprung mass
    and road input (physics/suspension_dynamics.py), integrated inside each communication
    step. A snap-through is the deflection leaving the stable region it was last in for the
    other one (near u < u* to far u > 2h - u*, or back), located as an integrator event and
    logged with its time.
    """

    description = (
        "Two-spring car suspension: static equilibrium under a load (continuation on "
        "the stable branches with snap-through detection), or with the dynamics "
        "effect a sprung mass with optional damper, tyre, unsprung mass and road input"
    )
    VARIABLES = (
        non_negative(
            "spring_free_length",
            physics.COURSEWORK_FREE_LENGTH,
            "L: free length of each spring",
            "m",
        ),
        non_negative(
            "spring_stiffness", physics.COURSEWORK_STIFFNESS, "k: stiffness of each spring", "N/m"
        ),
        non_negative(
            "spring_base_offset",
            physics.COURSEWORK_BASE_OFFSET,
            "d: horizontal distance of each spring's lower end from the centre line, in (0, L)",
            "m",
        ),
        parameter(
            "stop_on_snap_through",
            False,
            "true: a snap-through discards the step "
            "with an error instead of continuing on the far branch",
        ),
        effect("dynamics", "sprung mass: m u'' + F(u) = W (off: the static equilibrium)"),
        effect("damping", "viscous damper c u' in parallel with the springs (needs dynamics)"),
        effect(
            "tyre",
            "tyre spring k_t and unsprung mass m_u between the road and the spring "
            "base (needs dynamics)",
        ),
        effect(
            "road_input",
            "base excitation from the inputs road_height and road_rate (needs dynamics)",
        ),
        non_negative(
            "mass",
            dyn.DEFAULT_MASS,
            "m: sprung mass on the apex (dynamics; the load input carries its weight)",
            "kg",
        ),
        non_negative(
            "damping_coefficient",
            dyn.DEFAULT_DAMPING,
            "c: damper coefficient "
            "(damping; default gives damping ratio 0.3 at the coursework's stable "
            "equilibrium)",
            "N.s/m",
        ),
        non_negative(
            "tyre_stiffness", dyn.DEFAULT_TYRE_STIFFNESS, "k_t: tyre stiffness (tyre)", "N/m"
        ),
        non_negative(
            "unsprung_mass",
            dyn.DEFAULT_UNSPRUNG_MASS,
            "m_u: unsprung mass, carrying its weight m_u g on the tyre (tyre)",
            "kg",
        ),
        parameter(
            "initial_deflection",
            0.0,
            "u at the start (dynamics); with the tyre the "
            "unsprung mass starts at rest on a tyre carrying F(u) + m_u g",
            unit="m",
        ),
        parameter("initial_velocity", 0.0, "du/dt at the start (dynamics)", unit="m/s"),
        parameter(
            "input_interpolation",
            "interpolate",
            "Inputs inside a step (dynamics), from "
            "their values at both ends: interpolate (load linear, road cubic Hermite "
            "through heights and rates) or hold (values at the start of the step, exact "
            "for inputs that jump at communication points)",
            values=dyn.INPUT_MODES,
        ),
        *integrator_variables(default="dopri5"),
        input_("load", 0.0, "W: downward load on the spring apex", unit="N"),
        input_("road_height", 0.0, "r: road height, positive upward (road_input)", unit="m"),
        input_("road_rate", 0.0, "dr/dt (road_input)", unit="m/s"),
        output(
            "deflection",
            0.0,
            "u: downward deflection of the apex from the unstressed "
            "position, relative to the spring base",
            unit="m",
            depends=_INPUTS,
        ),
        output(
            "spring_force",
            0.0,
            "F(u): vertical force carried by the springs (equals the load at equilibrium)",
            unit="N",
            depends=_INPUTS,
        ),
        output(
            "secant_stiffness",
            0.0,
            "F/u (exact limit 2 k h^2 / L^2 at u = 0)",
            unit="N/m",
            depends=_INPUTS,
        ),
        output(
            "tangent_stiffness",
            0.0,
            "dF/du: decides stability and natural frequency",
            unit="N/m",
            depends=_INPUTS,
        ),
        output(
            "stable",
            True,
            "tangent_stiffness > MARGINAL_RTOL * 2 k (MARGINAL_RTOL = "
            f"{physics.MARGINAL_RTOL:g}): the equilibrium is stable",
            depends=_INPUTS,
        ),
        output(
            "marginal",
            False,
            "|tangent_stiffness| <= MARGINAL_RTOL * 2 k: a limit point "
            "(the load within LIMIT_LOAD_RTOL = "
            f"{physics.LIMIT_LOAD_RTOL:g} of the limit load), neither stable nor unstable; "
            "stable, marginal and unstable (both false) exclude each other",
            depends=_INPUTS,
        ),
        output(
            "snap_through",
            False,
            "true on a step where the load passed a limit load "
            "and the equilibrium jumped to the other stable branch (dynamics: the "
            "deflection crossed from one stable region to the other)",
            depends=_INPUTS,
        ),
        output(
            "branch",
            0,
            "Stable branch: 0 near (u < h - v*), 1 far (u > h + v*); "
            "dynamics: 2 while u is between them (unstable region)",
            depends=_INPUTS,
        ),
        output("snap_through_count", 0, "Number of snap-throughs so far", depends=_INPUTS),
        output("limit_load", 0.0, "F*: largest load the near branch can carry", unit="N"),
        output("limit_deflection", 0.0, "u*: deflection at the limit load", unit="m"),
        output("velocity", 0.0, "du/dt (0 in the static mode)", unit="m/s", depends=_INPUTS),
        output("acceleration", 0.0, "d2u/dt2 (0 in the static mode)", unit="m/s2", depends=_INPUTS),
        output(
            "sprung_displacement",
            0.0,
            "y: downward displacement of the sprung mass (u + unsprung_displacement)",
            unit="m",
            depends=_INPUTS,
        ),
        output(
            "unsprung_displacement",
            0.0,
            "z: downward displacement of the spring base "
            "(tyre: the unsprung mass; else -road_height)",
            unit="m",
            depends=_INPUTS,
        ),
        output(
            "tyre_force",
            0.0,
            "k_t (z + r): tyre compression force (tyre; 0 without)",
            unit="N",
            depends=_INPUTS,
        ),
        output("kinetic_energy", 0.0, "m y'^2 / 2 + m_u z'^2 / 2", unit="J", depends=_INPUTS),
        output(
            "potential_energy",
            0.0,
            "k (s - L)^2 (both springs) - W y + k_t (z + r)^2 / 2 "
            "- m_u g z; zero unstressed; conserved with T for a constant load, no damper, "
            "no road input",
            unit="J",
            depends=_INPUTS,
        ),
        *geometry_effect(
            "origin on the centre line at the height of the spring bases with the base "
            "at z = 0, +x right, +y up",
            {
                "left_base": "the left spring's lower end (-d, -z)",
                "right_base": "the right spring's lower end (d, -z)",
                "apex": "the springs' upper ends, where the load and the sprung mass act",
            },
            depends=_INPUTS,
            extra=(
                geometry_output(
                    "road_surface_y",
                    "road surface height above its level at rest (road_height with the "
                    "road_input effect, else 0); at rest it lies the tyre's undeformed "
                    "length below the origin (not modelled: a drawing chooses it)",
                    depends=_INPUTS,
                ),
            ),
        ),
    )

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        # ((free length, stiffness, base offset), Spring) of the last _spring()
        self._spring_cache: tuple[tuple[float, float, float], Spring] | None = None
        self.model: Any = None  # dynamics: the Model, right-hand side, inputs, events
        self.inputs: Any = None  # dyn.StepInputs (set_up)
        self.rhs: Any = None  # Callable (set_up)
        self.deflection_of: Any = None  # u(t, y)
        self.events: Any = None  # {side: (Event,)}
        self.side: Any = None  # last stable region visited: NEAR or FAR
        self.blowup: Any = None  # state max-norm beyond which the integration is unstable

    def _spring(self) -> Spring:
        """The validated Spring of the current parameters (validated again only when they
        changed: in initialisation mode)."""
        v = self.values
        key = (v["spring_free_length"], v["spring_stiffness"], v["spring_base_offset"])
        cached = self._spring_cache
        if cached is None or cached[0] != key:
            cached = self._spring_cache = (key, physics.make_spring(*key))
        return cached[1]

    # --- set-up (IntegratingSlave: the dynamics effect integrates (y, y'[, z, z'])) ----------
    def set_up(self) -> bool:
        v = self.values
        spring = self._spring()
        limit = physics.limit_point(spring)
        v["limit_load"], v["limit_deflection"] = limit.load, limit.deflection
        if not v["dynamics"]:
            enabled = [name for name in _DYNAMIC_EFFECTS if v[name]]
            if enabled:
                raise MechanismError(
                    f"effect(s) {', '.join(enabled)} need the dynamics effect "
                    f"(the static model has no masses)"
                )
            return False
        effects = dyn.Effects(v["damping"], v["tyre"], v["road_input"])
        self.model = dyn.make_model(
            spring,
            v["mass"],
            v["damping_coefficient"],
            v["tyre_stiffness"],
            v["unsprung_mass"],
            effects,
        )
        self.inputs = dyn.StepInputs(v["input_interpolation"])
        self.rhs = dyn.build_rhs(self.model, self.inputs)
        self.deflection_of = dyn.build_deflection(self.model, self.inputs)
        self.events = {
            side: (
                Event(
                    "snap_through",
                    dyn.snap_function(self.model, self.inputs, side),
                    +1 if side == dyn.NEAR else -1,
                ),
            )
            for side in (dyn.NEAR, dyn.FAR)
        }
        return True

    def outputs_at_start(self, time: float) -> None:
        if not self.values["dynamics"]:
            self.values["branch"] = physics.NEAR  # continuation starts from the unloaded state
        super().outputs_at_start(time)

    def initial_state(self, time: float) -> list[float]:
        v = self.values
        self.inputs.set_constant(time, *self.held_inputs)
        y = dyn.initial_state(
            self.model, v["initial_deflection"], v["initial_velocity"], self.inputs, time
        )
        self.blowup = BLOWUP_FACTOR * (1.0 + max(abs(x) for x in y))
        u = v["initial_deflection"]
        self.side = dyn.NEAR if u <= physics.rest_height(self.model.spring) else dyn.FAR
        v["snap_through"] = False
        return y

    def extra_state(self) -> dict[str, float | None]:
        return {"side": self.side, "blowup": self.blowup}

    def restore_extra_state(self, saved: dict[str, Any]) -> None:
        self.side, self.blowup = saved["side"], saved["blowup"]

    # --- stepping ----------------------------------------------------------------------------
    def read_inputs(self) -> tuple[float, float, float]:
        v = self.values
        return (
            require_finite("load", v["load"], "N"),
            require_finite("road_height", v["road_height"], "m"),
            require_finite("road_rate", v["road_rate"], "m/s"),
        )

    def update_without_state(self, time: float, step_size: float) -> None:
        """Static: the equilibrium under the load, continued along its branch."""
        v = self.values
        state, snapped = physics.follow_load(
            v["load"],
            v["branch"],
            self._spring(),
            guess=v["deflection"],
            continue_past_limit=not v["stop_on_snap_through"],
        )
        if snapped:
            self.log(
                f"{self.instance_name} at t = {time!r} s: snap-through: load = "
                f"{v['load']!r} N passed the limit of branch "
                f"{'near' if v['branch'] == physics.NEAR else 'far'}; deflection jumps "
                f"from {v['deflection']!r} m to {state.deflection!r} m",
                Status.warning,
            )
            v["snap_through_count"] += 1
        (
            v["deflection"],
            v["spring_force"],
            v["secant_stiffness"],
            v["tangent_stiffness"],
            v["stable"],
            v["branch"],
            v["marginal"],
        ) = state
        v["snap_through"] = snapped
        v["sprung_displacement"] = state.deflection
        v["potential_energy"] = (
            dyn.spring_energy(state.deflection, self._spring()) - v["load"] * state.deflection
        )

    def advance(self, start: float, time: float, end_inputs: tuple[float, float, float]) -> tuple:
        """Integrate to ``time`` through the snap-throughs; return (state, (snap-throughs
        as (t, u, side left), the stable region reached))."""
        v = self.values
        self.inputs.set_step(start, time, self.held_inputs, end_inputs)
        snaps = []
        side = [self.side]

        def snap(event: Any, t: float, y: Any):
            u = self.deflection_of(t, y)
            if v["stop_on_snap_through"]:
                raise SnapThrough(
                    f"dynamic snap-through at t = {t!r} s: deflection "
                    f"{u!r} m left the {_NAMES[side[0]]} stable region"
                )
            snaps.append((t, u, side[0]))
            side[0] = dyn.FAR if side[0] == dyn.NEAR else dyn.NEAR
            return y

        check_energy = dyn.passive(self.model, self.inputs)
        if check_energy:
            kinetic, potential, scale0 = dyn.energy(self.model, self.inputs, start, self.state)
            energy0 = kinetic + potential
        y = advance_through_events(
            self.integrator, self.rhs, start, self.state, time, lambda: self.events[side[0]], snap
        )
        if check_energy:
            kinetic, potential, scale = dyn.energy(self.model, self.inputs, time, y)
            if kinetic + potential - energy0 > ENERGY_GROWTH * max(scale0, scale):
                raise IntegrationError(
                    f"{v['integrator']}: the mechanical energy grew from {energy0:.6g} J "
                    f"to {kinetic + potential:.6g} J between t = {start!r} s and "
                    f"{time!r} s under a constant load (a passive system cannot gain "
                    f"energy): unstable: the sub-step max_substep = {v['max_substep']!r} s "
                    f"exceeds the method's stability limit; reduce max_substep or use "
                    f"radau"
                )
        if max(abs(x) for x in y) > self.blowup:
            raise IntegrationError(
                f"{v['integrator']}: solution blew up between t = {start!r} s and "
                f"{time!r} s (state max-norm {max(abs(x) for x in y):.3g} is more than "
                f"{BLOWUP_FACTOR:g} times 1 + that of the initial state): unstable: the "
                f"sub-step max_substep = {v['max_substep']!r} s exceeds the method's "
                f"stability limit; reduce max_substep or use radau"
            )
        return y, (snaps, side[0])

    def commit(self, time: float, happened: tuple) -> None:
        snaps, self.side = happened
        v = self.values
        for t_event, u, old in snaps:
            self.log(
                f"{self.instance_name} at t = {t_event!r} s: snap-through: deflection "
                f"{u!r} m went from the {_NAMES[old]} to the "
                f"{_NAMES[dyn.FAR if old == dyn.NEAR else dyn.NEAR]} stable region "
                f"(load {dyn.load_at(self.inputs, t_event)!r} N)",
                Status.warning,
            )
        v["snap_through"] = bool(snaps)
        v["snap_through_count"] += len(snaps)
        if self.inputs.mode == "hold":  # the value held from ``time`` on
            self.inputs.set_constant(time, *self.held_inputs)

    def publish(self, time: float) -> None:
        v = self.values
        spring = self.model.spring
        m = dyn.motion(self.model, self.inputs, self.rhs, time, self.state)
        (
            v["deflection"],
            v["velocity"],
            v["acceleration"],
            v["sprung_displacement"],
            v["unsprung_displacement"],
            v["tyre_force"],
            v["kinetic_energy"],
            v["potential_energy"],
        ) = m
        u = m.deflection
        v["spring_force"] = physics.spring_force(u, spring)
        v["secant_stiffness"] = physics.secant_stiffness(u, spring)
        v["tangent_stiffness"] = physics.tangent_stiffness(u, spring)
        v["stable"], v["marginal"] = physics.stability(v["tangent_stiffness"], spring)
        v["branch"] = dyn.region(u, spring)

    def geometry_points(self) -> dict[str, float]:
        v = self.values
        spring = self._spring()
        points = joint_positions.flattened(
            joint_positions.suspension_points(
                spring.base_offset,
                physics.rest_height(spring),
                v["deflection"],
                v["unsprung_displacement"],
            )
        )
        points["road_surface_y"] = v["road_height"] if v["road_input"] else 0.0
        return points


_NAMES = {dyn.NEAR: "near", dyn.FAR: "far"}
