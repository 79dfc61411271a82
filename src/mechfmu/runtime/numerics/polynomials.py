"""Polynomials as coefficient tuples (a0, a1, ...), p(tau) = sum a_j tau^j (standard library
only): evaluation with rates, derivative, shift of origin and a bound on the variation. Used by
the drives' step polynomials (stepping.hermite's fits, the valve's and the road's inputs) and
the exact valve integrator (linear_ode)."""


def polynomial(coefficients: tuple[float, ...] | list[float], tau: float) -> float:
    """p(tau) = sum a_j tau^j for coefficients (a0, a1, ...) (Horner)."""
    value = 0.0
    for a in reversed(coefficients):
        value = value * tau + a
    return value


def derivative(coefficients: tuple[float, ...] | list[float]) -> tuple[float, ...]:
    """Coefficients of p' for those of p."""
    return tuple(j * coefficients[j] for j in range(1, len(coefficients))) or (0.0,)


def shift(coefficients: tuple[float, ...] | list[float], delta: float) -> tuple[float, ...]:
    """Coefficients of q(s) = p(s + delta) (repeated synthetic division, Taylor at delta)."""
    a = list(coefficients)
    n = len(a)
    for i in range(n - 1):
        for j in range(n - 2, i - 1, -1):
            a[j] += delta * a[j + 1]
    return tuple(a)


def polynomial_motion(coefficients: tuple[float, ...], tau: float) -> tuple[float, float, float]:
    """(p, p', p'') at tau of p(tau) = sum a_k tau^k, coefficients (a0, a1, ...) (Horner)."""
    value = rate = rate2 = 0.0
    for a in reversed(coefficients):
        rate2 = rate2 * tau + 2.0 * rate
        rate = rate * tau + value
        value = value * tau + a
    return value, rate, rate2


def variation(coefficients: tuple[float, ...] | list[float], span: float) -> float:
    """A bound on |p(tau) - p(0)| for tau in [0, span] (s): sum of |a_j| span^j, j >= 1."""
    bound, power = 0.0, 1.0
    for a in coefficients[1:]:
        power *= span
        bound += abs(a) * power
    return bound
