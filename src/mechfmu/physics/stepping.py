"""Advance a model across one communication step through its events (standard library only)."""

from .errors import IntegrationError

MAX_EVENTS_PER_STEP = 1000


def advance_through_events(integrator, rhs, t, y, t_end, events, handle):
    """Integrate y' = rhs(t, y) from t to t_end, stopping at each terminal event.

    At an event the integrator returns the event time and state; ``handle(event, t, y)``
    records or logs it and returns the state to continue from (e.g. unchanged). The number
    of events per call is bounded, so chattering contacts end in an IntegrationError
    instead of a hang. Returns the state at t_end.
    """
    for _ in range(MAX_EVENTS_PER_STEP):
        step = integrator.advance(rhs, t, y, t_end, events)
        t, y = step.t, step.y
        if step.event is None:
            return y
        y = handle(step.event, t, y)
        if t >= t_end:
            return y
    raise IntegrationError(f"more than {MAX_EVENTS_PER_STEP} events before t = {t_end!r} s "
                           f"(last at t = {t!r} s): chattering; reduce the step or soften "
                           f"the contact")
