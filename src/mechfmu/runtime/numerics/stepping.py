"""Advance a model across one communication step through its events (standard library only)."""

from ..errors import IntegrationError
from . import polynomials
from .integrators import Event, Integrator
from collections.abc import Callable

MAX_EVENTS_PER_STEP = 1000


def advance_through_events(
    integrator: Integrator,
    rhs: Callable,
    t: float,
    y: list[float],
    t_end: float,
    events: Callable | list[Event],
    handle: Callable,
) -> list[float]:
    """Integrate y' = rhs(t, y) from t to t_end, stopping at each terminal event.

    At an event the integrator returns the event time and state; ``handle(event, t, y)``
    records or logs it and returns the state to continue from (e.g. unchanged). ``events``
    is the sequence of Events to watch, or a function returning it, asked again after each
    event (for a model whose events follow its mode, changed by ``handle``). The number
    of events per call is bounded, so chattering contacts end in an IntegrationError
    instead of a hang. Returns the state at t_end.
    """
    watched = events if callable(events) else (lambda: events)
    for _ in range(MAX_EVENTS_PER_STEP):
        step = integrator.advance(rhs, t, y, t_end, watched())
        t, y = step.t, step.y
        if step.event is None:
            return y
        y = handle(step.event, t, y)
        if t >= t_end:
            return y
    raise IntegrationError(
        f"more than {MAX_EVENTS_PER_STEP} events before t = {t_end!r} s "
        f"(last at t = {t!r} s): chattering; reduce the step or soften "
        f"the contact"
    )


# --- inputs inside one communication step -------------------------------------------------


def hermite(step: float, start: tuple[float, ...], end: tuple[float, ...]) -> tuple[float, ...]:
    """Hermite polynomial through an input's values and rates at both ends of a step.

    ``start`` and ``end`` are (value, rate) or (value, rate, second rate) at tau = 0 and
    tau = ``step`` (s); the result is the coefficients (a0, a1, ...) of
    p(tau) = sum a_k tau^k, cubic from two values per end, quintic from three, for
    polynomials.polynomial_motion. Written as the Taylor polynomial at the start plus the
    correction b_k = a_k step^k that meets the end values: with the end's misfits of that Taylor
    polynomial P (value), Q (rate, times step) and R (second rate, times step^2), the
    cubic has b2 = 3P - Q, b3 = Q - 2P and the quintic b3 = 10P - 4Q + R/2,
    b4 = -15P + 7Q - R, b5 = 6P - 3Q + R/2 (the solutions of the end conditions). Exact for
    polynomials of its degree; for smooth inputs the error is O(step^4) (cubic) or
    O(step^6) (quintic).
    """
    if len(start) != len(end) or len(start) not in (2, 3):
        raise ValueError(
            f"hermite needs (value, rate) or (value, rate, second rate) at both "
            f"ends, got {start!r} and {end!r}"
        )
    h = step
    if len(start) == 2:
        y0, v0 = start
        y1, v1 = end
        misfit = y1 - y0 - v0 * h
        rate_misfit = (v1 - v0) * h
        return (
            y0,
            v0,
            (3.0 * misfit - rate_misfit) / (h * h),
            (rate_misfit - 2.0 * misfit) / (h * h * h),
        )
    y0, v0, a0 = start
    y1, v1, a1 = end
    misfit = y1 - y0 - v0 * h - 0.5 * a0 * h * h
    rate_misfit = (v1 - v0 - a0 * h) * h
    second_misfit = (a1 - a0) * h * h
    h3 = h * h * h
    return (
        y0,
        v0,
        0.5 * a0,
        (10.0 * misfit - 4.0 * rate_misfit + 0.5 * second_misfit) / h3,
        (-15.0 * misfit + 7.0 * rate_misfit - second_misfit) / (h3 * h),
        (6.0 * misfit - 3.0 * rate_misfit + 0.5 * second_misfit) / (h3 * h * h),
    )


def hermite_nodes(step: float, motions: list[tuple[float, float, float]]) -> tuple[float, ...]:
    """Coefficients (a0, a1, ...) of the polynomial p(tau) of degree 3 n - 1 through the
    values, rates and second rates ``motions`` (n >= 2 triples) at the n equally spaced points
    tau = i step / (n - 1), i = 0 .. n - 1 (s): exact for polynomials of that degree,
    O(step^(3 n)) for smooth motions; n = 2 is ``hermite``'s quintic.

    Written as that quintic through both ends plus the correction that meets the interior
    points' misfits (zero at both ends with two derivatives): the correction's coefficients
    come from the inverse of the confluent Vandermonde matrix, whose entries grow to 1e6 for
    n = 4, applied to misfits of the size of the quintic's error, so its rounding stays that
    small (applied to the motions themselves it would cost 1e-12 of a 1e-2 value)."""
    base = hermite(step, motions[0], motions[-1])
    nodes = len(motions)
    if nodes == 2:
        return base
    rows = polynomials.interior_inverse(nodes)
    misfits: list[float] = []
    last = nodes - 1
    for i in range(1, last):
        value, rate, rate2 = polynomials.polynomial_motion(base, step * i / last)
        target = motions[i]
        misfits += (
            target[0] - value,
            (target[1] - rate) * step,
            (target[2] - rate2) * step * step,
        )
    coefficients = list(base) + [0.0] * (3 * nodes - len(base))
    # the correction and its two rates vanish at tau = 0: its rows 0 .. 2 are zero
    scale = 1.0 / step / step / step  # step^-j, divided as the rows go
    for j in range(3, len(rows)):
        total = 0.0
        for weight, misfit in zip(rows[j], misfits):
            total += weight * misfit
        coefficients[j] += total * scale
        scale /= step
    return tuple(coefficients)
