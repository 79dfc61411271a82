"""ODE integrators for the mechanism models (standard library only: they run inside FMUs).

One contract, four methods (the structure follows ``scipy.integrate._ivp``: a base class
that owns the loop, events and bookkeeping, and one small subclass per method whose
coefficients are data)::

    integrator = make_integrator("dopri5", rtol=1e-8, atol=1e-10, max_substep=1e-3)
    t, y, event = integrator.advance(rhs, t, y, t_end, events=(Event("ground", g),))

``advance`` integrates y' = rhs(t, y) (y a list of floats, rhs returning a list) from t to
t_end > t with internal sub-steps and returns ``Advance(t, y, event)``: either t == t_end
and event None, or the first terminal event in (t, t_end] with its time and state.

Methods (``METHODS``):

euler   explicit Euler, order 1, fixed sub-step h = min(max_substep, remaining).
rk4     classic 4-stage Runge-Kutta, order 4, fixed sub-step as euler.
dopri5  Dormand-Prince 5(4) with FSAL and an adaptive step size (local extrapolation).
radau   implicit Radau IIA, 3 stages, order 5, L-stable, adaptive (for stiff models).

Failures raise ``IntegrationError`` naming the method, the time and what to do. No call
returns NaN or infinity: every loop is bounded (``MAX_SUBSTEPS`` attempted sub-steps per
``advance`` call, ``NEWTON_MAXITER`` Newton iterations per stage solve,
``MAX_EVENT_ITERATIONS`` per event location), a call that would need more than
``MAX_SUBSTEPS`` sub-steps of ``max_substep`` is refused before it starts, and
``start_clock(seconds)`` bounds the wall-clock time of every call until the next
``start_clock`` (an FMU starts it at each communication step).

References
----------
[HNW]  E. Hairer, S. P. Norsett, G. Wanner, Solving Ordinary Differential Equations I,
       2nd ed., Springer 1993: II.1 (Runge-Kutta methods), II.4 (automatic step size
       control, starting step size), II.5 (Dormand-Prince pairs).
[HW]   E. Hairer, G. Wanner, Solving Ordinary Differential Equations II, 2nd ed.,
       Springer 1996: IV.5 (Radau IIA), IV.8 (implementation of implicit Runge-Kutta
       methods: simplified Newton, transformation to a real and a complex system,
       error estimate, predictive step size control) and the code RADAU5.
[DP]   J. R. Dormand, P. J. Prince, A family of embedded Runge-Kutta formulae,
       J. Comput. Appl. Math. 6 (1980) 19-26.
[G]    K. Gustafsson, Control-theoretic techniques for stepsize selection in implicit
       Runge-Kutta methods, ACM TOMS 20 (1994) 496-517.
[DJ]   M. Dowell, P. Jarratt, A modified regula falsi method for computing the root of an
       equation (the Illinois method), BIT 11 (1971) 168-174.
[SciPy] scipy.integrate._ivp (rk.py, radau.py, common.py): the structure, constants and
       the Radau IIA step are modelled on it.
"""

import copy
import math
import time
from collections import namedtuple

from ..errors import IntegrationError, MechanismError, RangeError
from .linalg import Singular as _Singular
from .roots import crosses, find_root
from .linalg import lu_factor as _lu_factor
from .linalg import lu_solve as _lu_solve
from typing import Any
from collections.abc import Callable

METHODS = ("euler", "rk4", "dopri5", "radau")

MAX_SUBSTEPS = 1_000_000  # attempted sub-steps (accepted + rejected) per advance() call
NEWTON_MAXITER = 6  # simplified Newton iterations per Radau stage solve (RADAU5 uses 7)
MAX_EVENT_ITERATIONS = 200  # root-finding iterations per event location (needs <= ~130)
GROWTH_LIMIT = 1e12  # fixed-step instability: |y|_max > GROWTH_LIMIT * (1 + |y0|_max)
EVENT_TOLERANCE = 1e-12  # event time located to EVENT_TOLERANCE * max(1, |t|) seconds

_HUGE = 1e150  # a state this large overflows products in any rhs: it has blown up
_EPS = 2.220446049250313e-16  # machine epsilon of IEEE double (sys.float_info.epsilon)
_SLIVER = 1e-9  # a remainder within this relative margin of max_substep is taken in one go
_STRETCH = 1.01  # adaptive steps this close to the end are stretched to land on it [HNW]
_CLOCK_EVERY = 32  # attempted sub-steps between two looks at the wall clock

Advance = namedtuple("Advance", "t y event")
Advance.__doc__ = """Result of Integrator.advance: time, state (list) and the Event or None."""


class Stats:
    """Work counters; they accumulate across advance() calls until reset().

    rhs_evaluations  calls of the right-hand side (steps, rejected steps, starting step
                     heuristic, event location and finite-difference Jacobians)
    substeps         accepted internal sub-steps
    rejected         rejected sub-step attempts (error test or Newton failure)
    jacobians        finite-difference Jacobians computed (radau)
    """

    __slots__ = ("rhs_evaluations", "substeps", "rejected", "jacobians")

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Set every counter to zero."""
        self.rhs_evaluations = 0
        self.substeps = 0
        self.rejected = 0
        self.jacobians = 0

    def as_dict(self) -> Any:
        return {name: getattr(self, name) for name in self.__slots__}

    def __repr__(self) -> str:
        return "Stats(" + ", ".join(f"{k}={v}" for k, v in self.as_dict().items()) + ")"


class Event:
    """A state function whose sign change is an event.

    function(t, y) -> float. direction +1 reports only rising crossings (- to +), -1 only
    falling ones (+ to -), 0 both. Only terminal events are reported by advance() (it stops
    at the first one); non-terminal events are accepted and ignored.

    A crossing is a step from a nonzero value g0 to a value g1 of the opposite sign or
    zero. A step starting exactly on the surface (g0 == 0) is no crossing, so a caller that
    restarts at an event does not retrigger it.
    """

    __slots__ = ("name", "function", "direction", "terminal")

    def __init__(
        self, name: str, function: Callable, direction: int = 0, terminal: bool = True
    ) -> None:
        if not callable(function):
            raise MechanismError(
                f"event {name!r}: function {function!r} is not callable; "
                "pass a function g(t, y) -> float"
            )
        if direction not in (-1, 0, 1):
            raise RangeError(
                "direction",
                direction,
                "{-1, 0, 1}",
                "",
                f"event {name!r}: +1 rising, -1 falling, 0 both",
            )
        self.name = name
        self.function = function
        self.direction = int(direction)
        self.terminal = bool(terminal)

    def __repr__(self) -> str:
        return (
            f"Event({self.name!r}, {self.function!r}, direction={self.direction}, "
            f"terminal={self.terminal})"
        )


# --- small numerical helpers ---------------------------------------------------------------


def _rms(values: list[float]) -> float:
    """Root mean square (the error norm of [HNW] II.4, eq. 4.11)."""
    return math.sqrt(math.fsum(v * v for v in values) / len(values))


def _max_abs(values: list[float]) -> float:
    return max(abs(v) for v in values)


def _copied(value: Any) -> Any:
    """A copy of an integrator attribute that shares nothing mutable with it (several times
    faster than copy.deepcopy on these few types, and taken at every communication step)."""
    if isinstance(value, (float, int, complex, bool, str, type(None))):
        return value
    if isinstance(value, list):
        return [_copied(item) for item in value]
    if isinstance(value, tuple) and type(value) is tuple:
        return tuple(_copied(item) for item in value)
    if isinstance(value, Stats):
        twin = Stats()
        for name in Stats.__slots__:
            setattr(twin, name, getattr(value, name))
        return twin
    return copy.deepcopy(value)


def _all_finite(values: list[float]) -> bool:
    return all(math.isfinite(v) for v in values)


def _scaled_rms(
    err: list[float], y_old: list[float], y_new: list[float], rtol: float, atol: float
) -> float:
    """RMS of err_i / (atol + rtol * max(|y_old_i|, |y_new_i|)); inf if anything is NaN."""
    total = 0.0
    for e, a, b in zip(err, y_old, y_new):
        scale = atol + rtol * max(abs(a), abs(b))
        q = e / scale if scale > 0.0 else (0.0 if e == 0.0 else math.inf)
        total += q * q
    value = math.sqrt(total / len(err))
    return value if math.isfinite(value) else math.inf


def _fmt(x: float) -> str:
    return f"{x:.6g}"


def _fmt_step(x: float) -> str:
    return f"{x:.3g}"


# --- the contract ----------------------------------------------------------------------------


class Integrator:
    """Base class: advance(), event location, validation and counters.

    A subclass sets ``method`` and implements

    _substep(f, t, y, t_limit) -> (t1, y1, start)
        one accepted sub-step from (t, y) to t1 <= t_limit (exactly t_limit when it goes to
        the limit); ``start`` is whatever the method needs to repeat a step from (t, y);
    _trial(f, t0, y0, tau, start) -> y(tau)
        ONE sub-step of the same method from (t0, y0) to tau in (t0, t1] (event location);
    _begin_call()
        forget per-call caches (the caller may have changed the state between calls).

    f is the counted, checked right-hand side. Step-size memory survives between calls
    (restart() forgets it, e.g. after a discontinuity in the model).
    """

    method: str | None = None

    def __init__(
        self, rtol: float = 1e-8, atol: float = 1e-10, max_substep: float = math.inf
    ) -> None:
        self.rtol = check_tolerance("rtol", rtol)
        self.atol = check_tolerance("atol", atol)
        if (
            isinstance(max_substep, bool)
            or not isinstance(max_substep, (int, float))
            or not max_substep > 0.0
        ):  # also rejects NaN
            raise RangeError(
                "max_substep",
                max_substep,
                "(0, inf]",
                "s",
                "the largest internal sub-step must be positive (inf: none)",
            )
        self.max_substep = float(max_substep)
        self.stats = Stats()
        self._budget = MAX_SUBSTEPS
        self._growth_limit = math.inf
        self.time_limit: float | None = None  # s of wall-clock time, set by start_clock
        self.deadline: float | None = None  # time.monotonic() value past which a call stops
        self.restart()

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(rtol={self.rtol!r}, atol={self.atol!r}, "
            f"max_substep={self.max_substep!r})"
        )

    def snapshot(self) -> dict[str, Any]:
        """Everything the integrator carries between calls (step size, Jacobian, counters),
        copied, for an FMU state; ``restore`` puts it back exactly."""
        return {name: _copied(value) for name, value in self.__dict__.items()}

    def restore(self, snapshot: dict[str, Any]) -> None:
        self.__dict__.update({name: _copied(value) for name, value in snapshot.items()})

    def restart(self) -> None:
        """Forget the step size (and Jacobian) carried over between advance() calls."""

    def start_clock(self, seconds: float) -> None:
        """Bound the wall-clock time from now until the next start_clock to ``seconds``
        (inf: no bound). A call that passes it raises IntegrationError: never a hang."""
        self.time_limit = check_wall_time(seconds)
        self.deadline = time.monotonic() + seconds if math.isfinite(seconds) else None

    # --- the one public operation -----------------------------------------------------------
    def advance(
        self,
        rhs: Callable,
        t: float,
        y: list[float],
        t_end: float,
        events: tuple | list[Event] = (),
    ) -> "Advance":
        """Integrate y' = rhs(t, y) from t to t_end (> t); see the module docstring.

        Returns Advance(t_end, y(t_end), None), or Advance(t_event, y(t_event), event) at
        the earliest terminal event crossing in (t, t_end]. The event time is located to
        EVENT_TOLERANCE * max(1, |t|) and the returned point is the bracket end on the far
        side of the surface (g has the new sign or is zero there), its state one sub-step
        of the method from the sub-step's start.
        """
        t, y, t_end = self._check_call(t, y, t_end)
        f = self._counted(rhs, len(y))
        watched = [e for e in events if _is_terminal(e)]
        g_old = [self._event_value(e, t, y) for e in watched]
        self._begin_call()
        self._budget = MAX_SUBSTEPS
        self._growth_limit = GROWTH_LIMIT * (1.0 + _max_abs(y))
        needed = (t_end - t) / self.max_substep
        if needed > MAX_SUBSTEPS:  # refused at once rather than after minutes of work
            raise IntegrationError(
                f"{self.method}: integrating from t = {_fmt(t)} s to t_end = {_fmt(t_end)} s "
                f"needs at least {needed:.3g} sub-steps of max_substep = "
                f"{_fmt_step(self.max_substep)} s, more than the bound of {MAX_SUBSTEPS}: "
                + self._too_many_advice
            )
        for _ in range(MAX_SUBSTEPS):
            remaining = t_end - t
            if remaining <= self.max_substep * (1.0 + _SLIVER):
                t_limit = t_end
            else:
                t_limit = t + self.max_substep
                if t_limit <= t:
                    raise IntegrationError(
                        f"{self.method}: max_substep = {_fmt_step(self.max_substep)} s is "
                        f"below the resolution of t = {_fmt(t)} s; increase max_substep"
                    )
            t1, y1, start = self._substep(f, t, y, t_limit)
            if not _all_finite(y1):  # safety net: subclasses reject or raise before this
                raise self._unstable(t1, t1 - t)
            self.stats.substeps += 1
            if watched:
                hit = self._find_event(f, watched, g_old, t, y, t1, y1, start)
                if hit is not None:
                    return hit
            t, y = t1, y1
            if t >= t_end:
                return Advance(t_end, y, None)
        raise self._too_many(t, t_end)

    # --- checks and bookkeeping ------------------------------------------------------------
    def _check_call(
        self, t: float, y: list[float], t_end: float
    ) -> tuple[float, list[float], float]:
        name = self.method
        try:
            t = float(t)
            t_end = float(t_end)
        except (TypeError, ValueError):
            raise IntegrationError(
                f"{name}: t = {t!r} and t_end = {t_end!r} must be numbers (s)"
            ) from None
        if not (math.isfinite(t) and math.isfinite(t_end)):
            raise IntegrationError(f"{name}: t = {t!r} s and t_end = {t_end!r} s must be finite")
        if not t_end > t:
            raise IntegrationError(
                f"{name}: t_end = {_fmt(t_end)} s is not after "
                f"t = {_fmt(t)} s; advance needs t_end > t (a positive "
                "interval to integrate over)"
            )
        try:
            y = [float(v) for v in y]
        except (TypeError, ValueError):
            raise IntegrationError(
                f"{name}: the state y = {y!r} at t = {_fmt(t)} s must be a list of numbers"
            ) from None
        if not y:
            raise IntegrationError(
                f"{name}: the state y at t = {_fmt(t)} s is empty; pass at least one state variable"
            )
        for i, v in enumerate(y):
            if not math.isfinite(v):
                raise IntegrationError(
                    f"{name}: y[{i}] = {v!r} at t = {_fmt(t)} s is not "
                    "finite; the state must be finite before integrating"
                )
        return t, y, t_end

    def _counted(self, rhs: Callable, n: int) -> Callable:
        """rhs wrapped: counts every call, returns a list of n floats or raises."""
        stats = self.stats
        name = self.method

        def f(t: float, y: Any):
            stats.rhs_evaluations += 1
            out = rhs(t, y)
            try:
                values = [float(v) for v in out]
            except (TypeError, ValueError):
                raise IntegrationError(
                    f"{name}: rhs returned {out!r} at t = {_fmt(t)} s; it "
                    "must return a list of numbers, one per state"
                ) from None
            if len(values) != n:
                raise IntegrationError(
                    f"{name}: rhs returned {len(values)} values at "
                    f"t = {_fmt(t)} s for a state of {n}; return one "
                    "derivative per state"
                )
            return values

        return f

    def _check_derivative(self, t: float, values: list[float]) -> None:
        """The derivative at an accepted (finite) state must be finite: else the model's."""
        if not _all_finite(values):
            raise IntegrationError(
                f"{self.method}: rhs returned a non-finite derivative "
                f"{values!r} at t = {_fmt(t)} s for a finite state; check "
                "the model and its inputs at that time"
            )

    def _spend(self, t: float, t_end_hint: float | None = None) -> None:
        """Count one attempted sub-step against the per-call budget."""
        self._budget -= 1
        if self._budget < 0:
            raise self._too_many(t, t_end_hint)
        if (
            self._budget % _CLOCK_EVERY == 0
            and self.deadline is not None
            and time.monotonic() > self.deadline
        ):
            raise IntegrationError(
                f"{self.method}: stopped at t = {_fmt(t)} s after more than the wall-clock "
                f"bound of {self.time_limit:g} s (max_wall_time) for one communication step; "
                "shorten the communication step, loosen rtol and atol, or raise max_wall_time"
            )

    def _too_many(self, t: float, t_end: float | None):
        where = f" (t_end = {_fmt(t_end)} s)" if t_end is not None else ""
        return IntegrationError(
            f"{self.method}: more than {MAX_SUBSTEPS} sub-steps in one "
            f"advance call, stopped at t = {_fmt(t)} s{where}: " + self._too_many_advice
        )

    _too_many_advice = "shorten the communication step"

    def _unstable(self, t: float, h: float) -> IntegrationError:
        return IntegrationError(
            f"{self.method}: solution blew up at t = {_fmt(t)} s with "
            f"sub-step {_fmt_step(h)} s (unstable: the step exceeds the "
            "method's stability limit; reduce max_substep or use radau)"
        )

    def _underflow(self, t: float, h: float, why: str) -> IntegrationError:
        return IntegrationError(
            f"{self.method}: step size {_fmt_step(h)} s underflows at t = {_fmt(t)} s: {why}"
        )

    def _initial_step(
        self, f: Callable, t: float, y: list[float], f0: list[float], h_limit: float, order: int
    ) -> float:
        """Starting step size by the heuristic of [HNW] II.4 (p. 169), as in SciPy.

        order is the order of the error estimator; one extra rhs evaluation.
        """
        rtol, atol = self.rtol, self.atol
        scale = [atol + abs(v) * rtol for v in y]
        d0 = _rms([v / s for v, s in zip(y, scale)])
        d1 = _rms([v / s for v, s in zip(f0, scale)])
        h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
        h0 = min(h0, h_limit)
        y1 = [v + h0 * d for v, d in zip(y, f0)]
        f1 = f(t + h0, y1)
        d2 = _rms([(b - a) / s for a, b, s in zip(f0, f1, scale)]) / h0
        if not math.isfinite(d2):
            return h0 * 1e-3
        if d1 <= 1e-15 and d2 <= 1e-15:
            h1 = max(1e-6, h0 * 1e-3)
        else:
            h1 = (0.01 / max(d1, d2)) ** (1.0 / (order + 1))
        return min(100.0 * h0, h1, self.max_substep)

    def _carry(self, h_wanted: float, h_taken: float, factor: float, limited: bool) -> float:
        """Next step size; a step cut short to land on t_end does not shrink the memory."""
        h_next = h_taken * factor
        if limited and h_taken < h_wanted and factor >= 1.0:
            h_next = max(h_next, h_wanted)
        return min(h_next, self.max_substep)

    # --- events ----------------------------------------------------------------------------
    def _event_value(self, event: Event, t: float, y: list[float]) -> float:
        try:
            g = float(event.function(t, list(y)))
        except (TypeError, ValueError):
            g = math.nan
        if not math.isfinite(g):
            raise IntegrationError(
                f"{self.method}: event {event.name!r} returned {g!r} at "
                f"t = {_fmt(t)} s; event functions must return finite "
                "numbers"
            )
        return g

    def _find_event(
        self,
        f: Callable,
        watched: list[Event],
        g_old: list[float],
        t0: float,
        y0: list[float],
        t1: float,
        y1: list[float],
        start: list[float] | tuple[list[float], float, list[list[float]]],
    ) -> Advance | None:
        """Earliest terminal crossing in (t0, t1] or None; g_old is updated in place."""
        best = None  # (t, y, event)
        g_new = [self._event_value(e, t1, y1) for e in watched]
        for i, event in enumerate(watched):
            g0, g1 = g_old[i], g_new[i]
            if not crosses(g0, g1, event.direction):
                continue
            t_hi, y_hi, g_hi = t1, y1, g1
            if best is not None:  # only look before the earliest event found so far
                g_b = self._event_value(event, best[0], best[1])
                if not crosses(g0, g_b, event.direction):
                    continue
                t_hi, y_hi, g_hi = best[0], best[1], g_b
            t_e, y_e = self._locate(f, event, t0, y0, g0, t_hi, y_hi, g_hi, start)
            if best is None or t_e < best[0]:
                best = (t_e, y_e, event)
        g_old[:] = g_new
        if best is None:
            return None
        return Advance(best[0], best[1], best[2])

    def _locate(
        self,
        f: Callable,
        event: Event,
        t0: float,
        y0: list[float],
        g0: float,
        b: float,
        y_b: list[float],
        g_b: float,
        start: Any,
    ) -> tuple[float, list[float]]:
        """Root of g in (t0, b] by the Illinois method [DJ] with bisection safeguard
        (roots.find_root): the bracket keeps g's old (nonzero) sign at its start, the new
        sign or 0 at its end. The state at a trial time tau is ONE sub-step of the method
        from (t0, y0)."""
        states = {b: y_b}

        def value(tau: float) -> float:
            y_tau = self._trial(f, t0, y0, tau, start)
            if not _all_finite(y_tau):
                raise IntegrationError(
                    f"{self.method}: the state became non-finite at "
                    f"t = {_fmt(tau)} s while locating event "
                    f"{event.name!r}; reduce max_substep or the tolerances"
                )
            states[tau] = y_tau
            return self._event_value(event, tau, y_tau)

        tolerance = EVENT_TOLERANCE * max(1.0, abs(b))
        t_event = find_root(value, t0, g0, b, g_b, tolerance, MAX_EVENT_ITERATIONS)
        return t_event, states[t_event]

    # --- subclass interface ----------------------------------------------------------------
    def _begin_call(self) -> None:
        pass

    def _substep(self, f: Any, t: float, y: Any, t_limit: Any):
        raise NotImplementedError

    def _trial(self, f: Any, t0: float, y0: Any, tau: Any, start: Any):
        raise NotImplementedError


def _is_terminal(event: Event) -> bool:
    if not hasattr(event, "function") or not hasattr(event, "direction"):
        raise MechanismError(f"events must be Event objects, got {event!r}")
    return getattr(event, "terminal", True)


def check_wall_time(seconds: float) -> float:
    """``seconds`` (max_wall_time, s) as a float, or RangeError unless in (0, inf]."""
    if (
        isinstance(seconds, bool) or not isinstance(seconds, (int, float)) or not seconds > 0.0
    ):  # also rejects NaN
        raise RangeError(
            "max_wall_time",
            seconds,
            "(0, inf]",
            "s",
            "the wall-clock bound of a communication step must be positive",
        )
    return float(seconds)


def check_tolerance(name: str, value: float) -> float:
    """``value`` as a float, or RangeError naming ``name`` unless finite and >= 0."""
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not math.isfinite(value)
        or value < 0.0
    ):
        raise RangeError(name, value, "[0, inf)", "", "a tolerance must be finite and >= 0")
    return float(value)


# --- explicit Runge-Kutta ------------------------------------------------------------------


def _explicit_stages(
    f: Callable,
    t: float,
    y: list[float],
    h: float,
    k1: list[float],
    A: tuple,
    C: tuple[float, ...],
    t_new: float,
) -> list[list[float]]:
    """Stages K_1..K_s of an explicit Runge-Kutta method (K_1 = k1 given) [HNW] II.1."""
    K = [k1]
    n = len(y)
    for i in range(1, len(C)):
        row = A[i]
        y_i = list(y)
        for m, a in enumerate(row):
            if a:
                ha = h * a
                k = K[m]
                for j in range(n):
                    y_i[j] += ha * k[j]
        c = C[i]
        K.append(f(t_new if c == 1.0 else t + c * h, y_i))
    return K


def _combine(
    y: list[float], h: float, weights: tuple[float, ...], K: list[list[float]]
) -> list[float]:
    """y + h * sum_i weights_i K_i."""
    out = list(y)
    n = len(y)
    for w, k in zip(weights, K):
        if w:
            hw = h * w
            for j in range(n):
                out[j] += hw * k[j]
    return out


class FixedStepRungeKutta(Integrator):
    """Explicit Runge-Kutta with the fixed sub-step h = min(max_substep, remaining).

    Tableau (A, B, C) as class data. With max_substep = inf one sub-step spans the call.

    Instability: beyond its stability limit an explicit method multiplies the unstable
    error component by |R(h lambda)| > 1 at every sub-step, a geometric growth. A sub-step
    whose state is not finite, or whose max-norm exceeds GROWTH_LIMIT = 1e12 times
    (1 + the max-norm at the start of the advance call), raises IntegrationError
    ("unstable"). Twelve orders of magnitude of growth within one call are far beyond any
    physical transient of a mechanism, while a stability violation reaches them within a
    few dozen sub-steps (e.g. 4 for euler with h lambda = -1000). If the growth is spread
    over many calls (one sub-step each), it is caught at the latest when the state passes
    1e150 and its derivative or the state overflows to a non-finite value.
    """

    A: tuple[tuple[float, ...], ...] = ()
    B: tuple[float, ...] = ()
    C: tuple[float, ...] = ()
    order: int | None = None
    _too_many_advice = "increase max_substep or shorten the communication step"

    def _substep(
        self, f: Callable, t: float, y: list[float], t_limit: float
    ) -> tuple[float, list[float], list[float]]:
        self._spend(t)
        h = t_limit - t
        k1 = f(t, y)
        if not _all_finite(k1) and _max_abs(y) > _HUGE:
            raise self._unstable(t, h)  # grown over several calls until f overflowed
        self._check_derivative(t, k1)
        y1 = self._finish(f, t, y, h, k1, t_limit)
        if not _all_finite(y1) or _max_abs(y1) > self._growth_limit:
            raise self._unstable(t_limit, h)
        return t_limit, y1, k1

    def _trial(
        self, f: Callable, t0: float, y0: list[float], tau: float, start: list[float]
    ) -> list[float]:
        return self._finish(f, t0, y0, tau - t0, start, tau)

    def _finish(
        self, f: Callable, t: float, y: list[float], h: float, k1: list[float], t_new: float
    ) -> list[float]:
        K = _explicit_stages(f, t, y, h, k1, self.A, self.C, t_new)
        return _combine(y, h, self.B, K)


class Euler(FixedStepRungeKutta):
    """Explicit (forward) Euler, order 1: y1 = y0 + h f(t0, y0). [HNW] I.7."""

    method = "euler"
    order = 1
    C = (0.0,)
    A = ((),)
    B = (1.0,)


class RK4(FixedStepRungeKutta):
    """The classic 4-stage Runge-Kutta method of order 4 (Kutta 1901). [HNW] II.1, Table 1.2."""

    method = "rk4"
    order = 4
    C = (0.0, 0.5, 0.5, 1.0)
    A = ((), (0.5,), (0.0, 0.5), (0.0, 0.0, 1.0))
    B = (1 / 6, 1 / 3, 1 / 3, 1 / 6)


class _Adaptive(Integrator):
    """An integrator with error control: each new sub-step is the last one times a factor,
    SAFETY * (the method's error estimate)^(-1/order) within [MIN_FACTOR, MAX_FACTOR]."""

    SAFETY = 0.9
    MIN_FACTOR = 0.2
    MAX_FACTOR = 5.0


class DormandPrince45(_Adaptive):
    """Dormand-Prince 5(4) [DP], [HNW] II.5 Table 5.2, propagating the 5th-order solution.

    FSAL: the 7th stage f(t + h, y1) is the first stage of the next step, so an accepted
    step costs 6 rhs evaluations (plus one f(t, y) at the start of each advance call, as
    the caller may change the state between calls, and one for the starting step size).

    Error norm: RMS of err_i / (atol + rtol * max(|y_old_i|, |y_new_i|)) with
    err = h * sum E_i K_i (E = B - B_hat). Step size controller ([HNW] II.4, eq. 4.13):
    h_new = h * min(5, max(0.2, 0.9 * err^(-1/5))), no growth right after a rejection.
    The step size is kept between advance() calls.
    """

    method = "dopri5"
    order = 5
    error_estimator_order = 4
    C = (0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0)
    A = (
        (),
        (1 / 5,),
        (3 / 40, 9 / 40),
        (44 / 45, -56 / 15, 32 / 9),
        (19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729),
        (9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656),
    )
    B = (35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84)
    E = (-71 / 57600, 0.0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40)
    _too_many_advice = (
        "the problem is probably stiff (an explicit method needs tiny steps "
        "to stay stable), use radau"
    )

    def restart(self) -> None:
        self._h: float | None = None
        self._k1 = None

    def _begin_call(self) -> None:
        self._k1 = None

    def _substep(
        self, f: Callable, t: float, y: list[float], t_limit: float
    ) -> tuple[float, list[float], list[float]]:
        k1 = self._k1
        if k1 is None:
            k1 = f(t, y)
            self._check_derivative(t, k1)
        h = self._h
        if h is None:
            h = self._initial_step(f, t, y, k1, t_limit - t, self.error_estimator_order)
        h = min(h, self.max_substep)
        exponent = -1.0 / (self.error_estimator_order + 1)
        rejected = False
        while True:
            self._spend(t)
            min_step = 10.0 * math.ulp(t)
            if h < min_step:
                raise self._underflow(
                    t, h, "the problem is too stiff for an explicit method, use radau"
                )
            limited = h * _STRETCH >= t_limit - t
            t_new = t_limit if limited else t + h
            h_try = t_new - t
            K = _explicit_stages(f, t, y, h_try, k1, self.A, self.C, t_new)
            y_new = _combine(y, h_try, self.B, K)
            k7 = f(t_new, y_new)
            K.append(k7)
            err = _combine([0.0] * len(y), h_try, self.E, K)
            error = _scaled_rms(err, y, y_new, self.rtol, self.atol)
            if not (_all_finite(y_new) and _all_finite(k7)):
                error = math.inf
            if error <= 1.0:
                factor = (
                    self.MAX_FACTOR
                    if error == 0.0
                    else min(self.MAX_FACTOR, self.SAFETY * error**exponent)
                )
                if rejected:
                    factor = min(1.0, factor)
                self._h = self._carry(h, h_try, factor, limited)
                self._k1 = k7
                return t_new, y_new, k1
            self.stats.rejected += 1
            rejected = True
            factor = (
                self.MIN_FACTOR
                if error == math.inf
                else max(self.MIN_FACTOR, self.SAFETY * error**exponent)
            )
            h = h_try * factor

    def _trial(
        self, f: Callable, t0: float, y0: list[float], tau: float, start: list[float]
    ) -> list[float]:
        h = tau - t0
        K = _explicit_stages(f, t0, y0, h, start, self.A, self.C, tau)
        return _combine(y0, h, self.B, K)


# --- Radau IIA -------------------------------------------------------------------------------

_S6 = 6**0.5


class RadauIIA5(_Adaptive):
    """Implicit Radau IIA, 3 stages, order 5, stiffly accurate and L-stable [HW] IV.5, IV.8.

    Each step solves the stage system Z_i = h sum_j a_ij f(t + c_j h, y + Z_j) by
    simplified Newton iterations with a fixed finite-difference Jacobian J. The iteration
    matrix is decoupled by the eigen-decomposition of A^-1 into one real and one complex
    n x n system, (mu_real/h I - J) and (mu_complex/h I - J), factorised here by LU with
    partial pivoting ([HW] IV.8, eqs. 8.15-8.19). At most NEWTON_MAXITER iterations; the
    iteration stops early when the observed contraction rate predicts it cannot converge.

    J is computed by forward differences (column j with delta = sqrt(eps * max(1e-5,
    |y_j|)), as RADAU5) and reused across steps and calls until Newton converges slowly
    (more than 2 iterations at a rate > 1e-3) or fails; a failure with a fresh J halves
    the step.

    Error estimate ([HW] IV.8, eq. 8.20, with the stiff correction 8.21 after a rejection)
    and Gustafsson's predictive step size controller [G] with safety 0.9 scaled by the
    Newton effort, factor limits [0.2, 10], step kept when the change would be below 20 %
    (so the factorisations are reused). Constants and step as in SciPy's Radau.
    """

    method = "radau"
    order = 5
    error_estimator_order = 3
    C = ((4 - _S6) / 10, (4 + _S6) / 10, 1.0)
    A = (
        ((88 - 7 * _S6) / 360, (296 - 169 * _S6) / 1800, (-2 + 3 * _S6) / 225),
        ((296 + 169 * _S6) / 1800, (88 + 7 * _S6) / 360, (-2 - 3 * _S6) / 225),
        ((16 - _S6) / 36, (16 + _S6) / 36, 1 / 9),
    )
    # Error estimate weights (SciPy radau.E: Hairer's e_i divided by gamma_0)
    E = ((-13 - 7 * _S6) / 3, (-13 + 7 * _S6) / 3, -1 / 3)
    # Eigenvalues of A^-1: one real, one complex pair
    MU_REAL = 3 + 3 ** (2 / 3) - 3 ** (1 / 3)
    MU_COMPLEX = complex(
        3 + 0.5 * (3 ** (1 / 3) - 3 ** (2 / 3)), -0.5 * (3 ** (5 / 6) + 3 ** (7 / 6))
    )
    # A^-1 = T diag(mu_real, [[a, -b], [b, a]]) T^-1 (SciPy radau.T, radau.TI)
    T = (
        (0.09443876248897524, -0.14125529502095421, 0.03002919410514742),
        (0.25021312296533332, 0.20412935229379994, -0.38294211275726192),
        (1.0, 1.0, 0.0),
    )
    TI = (
        (4.17871859155190428, 0.32768282076106237, 0.52337644549944951),
        (-4.17871859155190428, -0.32768282076106237, 0.47662355450055044),
        (0.50287263494578682, -2.57192694985560522, 0.59603920482822492),
    )
    MAX_FACTOR = 10.0
    _too_many_advice = (
        "the solution varies too fast for the tolerances; check the model "
        "for discontinuities or loosen rtol/atol"
    )

    def restart(self) -> None:
        self._h: float | None = None
        self._h_old: float | None = None
        self._error_old: float | None = None
        self._J: list[list[float]] | None = None
        self._J_version = 0
        self._J_current = False
        self._jac_due = False
        self._lu: tuple | None = None  # (h, J_version, LU_real, LU_complex)
        self._begin_call()

    def _begin_call(self) -> None:
        self._f0 = None
        self._previous: tuple | None = (
            None  # (h, Z) of the last accepted step, for the Newton guess
        )
        self._J_current = False

    @property
    def _newton_tol(self) -> float:
        return max(10 * _EPS / max(self.rtol, 1e-300), min(0.03, self.rtol**0.5))

    def _jacobian(
        self, f: Callable, t: float, y: list[float], f0: list[float]
    ) -> list[list[float]]:
        """Forward-difference Jacobian (n rhs evaluations), RADAU5's increments."""
        n = len(y)
        J = [[0.0] * n for _ in range(n)]
        for j in range(n):
            y_j = y[j]
            perturbed = list(y)
            perturbed[j] = y_j + math.sqrt(_EPS * max(1e-5, abs(y_j)))
            delta = perturbed[j] - y_j
            f_j = f(t, perturbed)
            for i in range(n):
                J[i][j] = (f_j[i] - f0[i]) / delta
        self.stats.jacobians += 1
        for row in J:
            if not _all_finite(row):
                raise IntegrationError(
                    f"radau: the finite-difference Jacobian is not finite "
                    f"at t = {_fmt(t)} s; the model's derivative is not "
                    "defined there (check its state and inputs)"
                )
        self._J = J
        self._J_version += 1
        self._J_current = True
        self._jac_due = False
        return J

    def _factor(self, h: float) -> tuple:
        """LU factors of mu_real/h I - J and mu_complex/h I - J, cached per (h, J)."""
        cached = self._lu
        if cached is not None and cached[0] == h and cached[1] == self._J_version:
            return cached[2], cached[3]
        J = self._J
        assert J is not None  # _jacobian ran before the first factorisation
        n = len(J)
        real = [
            [(self.MU_REAL / h if i == j else 0.0) - J[i][j] for j in range(n)] for i in range(n)
        ]
        cplx = [
            [(self.MU_COMPLEX / h if i == j else 0.0) - J[i][j] for j in range(n)] for i in range(n)
        ]
        lu_real, lu_complex = _lu_factor(real), _lu_factor(cplx)
        self._lu = (h, self._J_version, lu_real, lu_complex)
        return lu_real, lu_complex

    def _newton(
        self,
        f: Callable,
        t: float,
        y: list[float],
        h: float,
        Z0: list[list[float]],
        lu_real: tuple[list[list[float]], list[int]],
        lu_complex: tuple,
    ) -> tuple:
        """Simplified Newton on the transformed stage system (SciPy solve_collocation_system).

        Returns (converged, iterations, Z, rate).
        """
        n = len(y)
        T, TI, C = self.T, self.TI, self.C
        m_real = self.MU_REAL / h
        m_complex = self.MU_COMPLEX / h
        scale = [self.atol + abs(v) * self.rtol for v in y]
        tol = self._newton_tol
        W = [
            [TI[i][0] * Z0[0][j] + TI[i][1] * Z0[1][j] + TI[i][2] * Z0[2][j] for j in range(n)]
            for i in range(3)
        ]
        Z = Z0
        norm_old = None
        rate = None
        k = 0
        for k in range(NEWTON_MAXITER):
            F = []
            for i in range(3):
                y_i = [a + b for a, b in zip(y, Z[i])]
                F.append(f(t + h if C[i] == 1.0 else t + C[i] * h, y_i))
            if not all(_all_finite(row) for row in F):
                return False, k + 1, Z, rate
            f_real = [
                TI[0][0] * F[0][j] + TI[0][1] * F[1][j] + TI[0][2] * F[2][j] - m_real * W[0][j]
                for j in range(n)
            ]
            f_complex = [
                complex(
                    TI[1][0] * F[0][j] + TI[1][1] * F[1][j] + TI[1][2] * F[2][j],
                    TI[2][0] * F[0][j] + TI[2][1] * F[1][j] + TI[2][2] * F[2][j],
                )
                - m_complex * complex(W[1][j], W[2][j])
                for j in range(n)
            ]
            d_real = _lu_solve(lu_real, f_real)
            d_complex = _lu_solve(lu_complex, f_complex)
            dW = (d_real, [z.real for z in d_complex], [z.imag for z in d_complex])
            norm = _rms([dW[i][j] / scale[j] for i in range(3) for j in range(n)])
            if not math.isfinite(norm):
                return False, k + 1, Z, rate
            if norm_old is not None:
                rate = norm / norm_old
                if rate >= 1.0 or rate ** (NEWTON_MAXITER - k) / (1 - rate) * norm > tol:
                    return False, k + 1, Z, rate
            for i in range(3):
                W_i, dW_i = W[i], dW[i]
                for j in range(n):
                    W_i[j] += dW_i[j]
            Z = [
                [T[i][0] * W[0][j] + T[i][1] * W[1][j] + T[i][2] * W[2][j] for j in range(n)]
                for i in range(3)
            ]
            if norm == 0.0 or (rate is not None and rate / (1 - rate) * norm < tol):
                return True, k + 1, Z, rate
            norm_old = norm
        return False, k + 1, Z, rate

    def _guess(
        self,
        previous: tuple[float, list[list[float]]],
        s_values: list[float],
        shift: list[float] | None,
    ) -> list[list[float]]:
        """Stage guess from the collocation polynomial of a step (h_p, Z_p): P(s) - shift.

        P interpolates 0 at s = 0 and Z_p[i] at s = C[i] (s in units of h_p).
        """
        nodes = (0.0,) + self.C
        _, Z = previous
        n = len(Z[0])
        out = []
        for s in s_values:
            value = [-v for v in shift] if shift is not None else [0.0] * n
            for k in range(1, 4):
                weight = 1.0
                for m in range(4):
                    if m != k:
                        weight *= (s - nodes[m]) / (nodes[k] - nodes[m])
                z = Z[k - 1]
                for j in range(n):
                    value[j] += weight * z[j]
            out.append(value)
        return out

    def _solve_stages(
        self,
        f: Callable,
        t: float,
        y: list[float],
        f0: list[float],
        h: float,
        Z0: list[list[float]],
    ) -> tuple:
        """Newton with the current J; one retry with a fresh J. Returns (ok, iters, Z, rate)."""
        while True:
            lu_real = None
            try:
                lu_real, lu_complex = self._factor(h)
            except _Singular:
                converged, n_iter, Z, rate = False, 0, Z0, None
            else:
                converged, n_iter, Z, rate = self._newton(f, t, y, h, Z0, lu_real, lu_complex)
            if converged or self._J_current:
                return converged, n_iter, Z, rate, (lu_real if converged else None)
            self._jacobian(f, t, y, f0)

    def _substep(
        self, f: Callable, t: float, y: list[float], t_limit: float
    ) -> tuple[float, list[float], tuple[list[float], float, list[list[float]]]]:
        f0 = self._f0
        if f0 is None:
            f0 = f(t, y)
            self._check_derivative(t, f0)
            self._f0 = f0
        n = len(y)
        if self._J is None or len(self._J) != n or self._jac_due:
            self._jacobian(f, t, y, f0)
        h = self._h
        h_old, error_old = self._h_old, self._error_old
        if h is None:
            h = self._initial_step(f, t, y, f0, t_limit - t, self.error_estimator_order)
            h_old = error_old = None
        if h > self.max_substep:
            h = self.max_substep
            h_old = error_old = None
        rejected = False
        while True:
            self._spend(t)
            min_step = 10.0 * math.ulp(t)
            if h < min_step:
                raise self._underflow(
                    t,
                    h,
                    "Newton iterations keep failing or the error "
                    "test cannot be met; check the model for "
                    "discontinuities or non-finite derivatives, or loosen "
                    "rtol/atol",
                )
            limited = h * _STRETCH >= t_limit - t
            t_new = t_limit if limited else t + h
            h_try = t_new - t
            if self._previous is None:
                Z0 = [[0.0] * n for _ in range(3)]
            else:
                h_p, Z_p = self._previous
                Z0 = self._guess(self._previous, [1.0 + c * h_try / h_p for c in self.C], Z_p[2])
            converged, n_iter, Z, rate, lu_real = self._solve_stages(f, t, y, f0, h_try, Z0)
            if not converged:
                self.stats.rejected += 1
                rejected = True
                h = 0.5 * h_try
                continue
            y_new = [a + b for a, b in zip(y, Z[2])]
            E = self.E
            ZE = [(E[0] * Z[0][j] + E[1] * Z[1][j] + E[2] * Z[2][j]) / h_try for j in range(n)]
            err = _lu_solve(lu_real, [a + b for a, b in zip(f0, ZE)])
            error = _scaled_rms(err, y, y_new, self.rtol, self.atol)
            safety = self.SAFETY * (2 * NEWTON_MAXITER + 1) / (2 * NEWTON_MAXITER + n_iter)
            if rejected and error > 1.0 and math.isfinite(error):
                y_err = [a + b for a, b in zip(y, err)]
                f_err = f(t, y_err)
                if _all_finite(f_err):
                    err = _lu_solve(lu_real, [a + b for a, b in zip(f_err, ZE)])
                    error = _scaled_rms(err, y, y_new, self.rtol, self.atol)
            if not _all_finite(y_new):
                error = math.inf
            if error > 1.0:
                factor = _predict_factor(h_try, h_old, error, error_old)
                self.stats.rejected += 1
                rejected = True
                h = h_try * max(self.MIN_FACTOR, safety * factor)
                continue
            break
        recompute_jac = n_iter > 2 and rate is not None and rate > 1e-3
        factor = _predict_factor(h_try, h_old, error, error_old)
        factor = min(self.MAX_FACTOR, safety * factor)
        if not recompute_jac and factor < 1.2:
            factor = 1.0
        self._h = self._carry(h, h_try, factor, limited)
        self._h_old, self._error_old = h_try, error
        self._jac_due = recompute_jac
        self._J_current = False
        self._f0 = None  # f(t_new, y_new) is evaluated when (if) the next step starts
        self._previous = (h_try, Z)
        return t_new, y_new, (f0, h_try, Z)

    def _trial(
        self, f: Callable, t0: float, y0: list[float], tau: float, start: Any
    ) -> list[float]:
        f0, h_step, Z_step = start
        h = tau - t0
        Z0 = self._guess((h_step, Z_step), [c * h / h_step for c in self.C], None)
        converged, _, Z, _, _ = self._solve_stages(f, t0, y0, f0, h, Z0)
        if not converged:
            # Newton can stall on a trial sub-step much shorter than the accepted one (its
            # increments sink to rounding level, which reads as divergence). The accepted
            # step's collocation polynomial is the continuous extension of the same solution
            # ([HW] IV.8, order 3 inside the step), so the event is located on it instead.
            return [a + b for a, b in zip(y0, Z0[2])]
        return [a + b for a, b in zip(y0, Z[2])]


def _predict_factor(h: float, h_old: float | None, error: float, error_old: float | None) -> float:
    """Gustafsson's predictive controller [G], [HW] IV.8 eq. 8.25 (as SciPy)."""
    if error == 0.0:
        return math.inf
    if error_old is None or h_old is None:
        multiplier = 1.0
    else:
        multiplier = h / h_old * (error_old / error) ** 0.25
    return min(1.0, multiplier) * error**-0.25


_CLASSES = {"euler": Euler, "rk4": RK4, "dopri5": DormandPrince45, "radau": RadauIIA5}


def make_integrator(
    method: str, rtol: float = 1e-8, atol: float = 1e-10, max_substep: float = math.inf
) -> Integrator:
    """A new integrator: method in METHODS; rtol, atol >= 0; max_substep in (0, inf] s.

    rtol and atol steer the adaptive methods (dopri5, radau); max_substep bounds every
    internal sub-step and is the fixed sub-step of euler and rk4.
    """
    cls = _CLASSES.get(method) if isinstance(method, str) else None
    if cls is None:
        raise MechanismError(
            f"integrator = {method!r} is not a known method; choose one of " + ", ".join(METHODS)
        )
    if method in ("dopri5", "radau"):
        rtol_value = check_tolerance("rtol", rtol)
        if rtol_value < 100 * _EPS:
            raise RangeError(
                "rtol",
                rtol,
                f"[{100 * _EPS:.3g}, inf)",
                "",
                f"{method} cannot meet a relative tolerance below 100 machine epsilons",
            )
    return cls(rtol=rtol, atol=atol, max_substep=max_substep)
