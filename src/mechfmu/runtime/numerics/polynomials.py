"""Polynomials as coefficient tuples (a0, a1, ...), p(tau) = sum a_j tau^j (standard library
only): evaluation with rates, derivative, shift of origin and a bound on the variation. Used by
the drives' step polynomials (stepping.hermite's fits, the valve's and the road's inputs) and
the exact valve integrator (linear_ode)."""

from functools import lru_cache


def polynomial(coefficients: tuple[float, ...] | list[float], tau: float) -> float:
    """p(tau) = sum a_j tau^j for coefficients (a0, a1, ...) (Horner)."""
    value = 0.0
    for a in reversed(coefficients):
        value = value * tau + a
    return value


def complex_polynomial(coefficients: tuple[complex, ...] | list[complex], tau: float) -> complex:
    """p(tau) for complex coefficients (a0, a1, ...) (Horner; the exact valve's exponential
    integrals). Its own function: a compiled core (packaging/compiled.py) checks that
    ``polynomial`` returns a float."""
    value: complex = 0.0  # a float until the first complex term, as ``polynomial`` computes
    for a in reversed(coefficients):
        value = value * tau + a
    return value


def derivative(coefficients: tuple[float, ...] | list[float]) -> tuple[float, ...]:
    """Coefficients of p' for those of p."""
    return tuple([j * coefficients[j] for j in range(1, len(coefficients))]) or (0.0,)


def combine(
    first_weight: float,
    first: tuple[float, ...] | list[float],
    second_weight: float,
    second: tuple[float, ...] | list[float],
) -> list[float]:
    """Coefficients of w1 p + w2 q for the weights and the coefficients of p and q, the
    shorter padded with zeros."""
    if len(first) < len(second):
        first_weight, first, second_weight, second = second_weight, second, first_weight, first
    result = [first_weight * a for a in first]
    for j, b in enumerate(second):
        result[j] += second_weight * b
    return result


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


def product(
    first: tuple[float, ...] | list[float], second: tuple[float, ...] | list[float]
) -> tuple[float, ...]:
    """Coefficients of p q for those of p and q."""
    result = [0.0] * (len(first) + len(second) - 1)
    for i, a in enumerate(first):
        for j, b in enumerate(second, i):
            result[j] += a * b
    return tuple(result)


def antiderivative(coefficients: tuple[float, ...] | list[float]) -> tuple[float, ...]:
    """Coefficients of the integral of p from 0 (its value at 0 is 0)."""
    return (0.0, *[a / (j + 1) for j, a in enumerate(coefficients)])


def change_bounds(
    coefficients: tuple[float, ...] | list[float], start: float, end: float
) -> tuple[float, float]:
    """(lowest, highest): bounds on p(tau) - p(start) for tau in [start, end] (s,
    0 <= start <= end), lowest <= 0 <= highest. Each term a_j (tau^j - start^j), j >= 1,
    keeps the sign of a_j and grows in size with tau, so the negative terms at ``end`` sum to
    the lower bound and the positive ones to the upper (a rising p is not taken to fall)."""
    lowest = highest = 0.0
    power_start = power_end = 1.0
    for a in coefficients[1:]:
        power_start *= start
        power_end *= end
        change = a * (power_end - power_start)
        if change < 0.0:
            lowest += change
        else:
            highest += change
    return lowest, highest


def _falling(j: int, order: int) -> int:
    """j (j - 1) ... (j - order + 1): the factor of u^(j - order) in d^order u^j / du^order."""
    factor = 1  # not "product": that is this module's polynomial product
    for i in range(order):
        factor *= j - i
    return factor


@lru_cache(maxsize=None)
def confluent_inverse(nodes: int) -> tuple[tuple[float, ...], ...]:
    """Inverse of the confluent Vandermonde matrix that takes the coefficients of a polynomial
    q(u) of degree 3 nodes - 1 to (q, q', q'') at the ``nodes`` points u = i / (nodes - 1)
    (Gauss-Jordan with partial pivoting; its rounding, about 1e-16 of its entries, only ever
    multiplies small misfits: stepping.hermite_nodes)."""
    size = 3 * nodes
    rows: list[list[float]] = []
    for i in range(nodes):
        u = i / (nodes - 1)
        for order in range(3):
            row = [
                float(_falling(j, order)) * u ** (j - order) if j >= order else 0.0
                for j in range(size)
            ]
            rows.append(row + [float(k == len(rows)) for k in range(size)])
    for column in range(size):
        pivot = max(range(column, size), key=lambda r: abs(rows[r][column]))
        rows[column], rows[pivot] = rows[pivot], rows[column]
        lead = rows[column][column]
        rows[column] = [value / lead for value in rows[column]]
        for r in range(size):
            factor = rows[r][column]
            if r != column and factor != 0.0:
                rows[r] = [a - factor * b for a, b in zip(rows[r], rows[column])]
    return tuple(tuple(row[size:]) for row in rows)


@lru_cache(maxsize=None)
def interior_inverse(nodes: int) -> tuple[tuple[float, ...], ...]:
    """The rows of confluent_inverse(nodes) restricted to the data of the interior points
    (those of the two ends are the quintic's: stepping.hermite_nodes)."""
    return tuple(row[3 : 3 * nodes - 3] for row in confluent_inverse(nodes))
