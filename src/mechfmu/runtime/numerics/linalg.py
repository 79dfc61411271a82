"""Small dense linear algebra for the integrators and the constraint solver (stdlib only).

The systems are tiny (Radau's 3-stage Newton matrix, a planar mechanism's 9 x 9 constraint
Jacobian), so plain Python lists beat any setup cost; what matters is partial pivoting, an
explicit failure on a singular matrix, and a condition number that says how far from
singular a matrix is (the constraint solver reports toggle and change points by it).
"""

from typing import Any
import math


class Singular(Exception):
    """Raised by lu_factor on an exactly singular or non-finite matrix."""


def lu_factor(matrix: list[list[Any]]) -> tuple[list[list[Any]], list[int]]:
    """LU factorisation with partial pivoting of a small dense square matrix.

    Works for real and complex entries (Python arithmetic). Returns (lu, pivots) with L
    (unit lower, below the diagonal) and U stored in one list of rows; raises Singular
    if a pivot is exactly zero or not finite. Doolittle form, Golub & Van Loan 3.4.
    """
    lu = [list(row) for row in matrix]
    n = len(lu)
    pivots = list(range(n))
    for k in range(n):
        p = max(range(k, n), key=lambda i: abs(lu[i][k]))
        pivot = lu[p][k]
        if pivot == 0 or not math.isfinite(abs(pivot)):
            raise Singular()
        if p != k:
            lu[k], lu[p] = lu[p], lu[k]
            pivots[k], pivots[p] = pivots[p], pivots[k]
        row_k = lu[k]
        for i in range(k + 1, n):
            row_i = lu[i]
            m = row_i[k] / pivot
            if m != 0:
                row_i[k] = m
                for j in range(k + 1, n):
                    row_i[j] -= m * row_k[j]
            else:
                row_i[k] = 0.0
    return lu, pivots


def lu_solve(factored: tuple[list[list[Any]], list[int]], b: list[Any]) -> list[Any]:
    """Solve A x = b given lu_factor(A) (forward then back substitution)."""
    lu, pivots = factored
    n = len(lu)
    x = [b[p] for p in pivots]
    for i in range(n):
        row = lu[i]
        s = x[i]
        for j in range(i):
            s -= row[j] * x[j]
        x[i] = s
    for i in range(n - 1, -1, -1):
        row = lu[i]
        s = x[i]
        for j in range(i + 1, n):
            s -= row[j] * x[j]
        x[i] = s / row[i]
    return x


def determinant_sign(factored: tuple[list[list[float]], list[int]]) -> int:
    """Sign (+1 or -1) of det(A) from lu_factor(A): product of U's diagonal signs times the
    permutation's parity. Zero determinants never reach here (lu_factor raises)."""
    lu, pivots = factored
    sign = 1
    for i, row in enumerate(lu):
        if row[i] < 0:
            sign = -sign
    # Parity of the permutation by counting cycles.
    seen = [False] * len(pivots)
    for start in range(len(pivots)):
        if seen[start]:
            continue
        length, j = 0, start
        while not seen[j]:
            seen[j] = True
            j = pivots[j]
            length += 1
        if length % 2 == 0:
            sign = -sign
    return sign


def one_norm(matrix: list[list[float]]) -> float:
    """Largest column sum of absolute values."""
    n = len(matrix[0])
    return max(sum(abs(row[j]) for row in matrix) for j in range(n))


def condition_number(
    matrix: list[list[float]], factored: tuple[list[list[float]], list[int]] | None = None
) -> float:
    """1-norm condition number ||A|| ||A^-1|| (exact: A^-1 column by column; n is small).

    Returns math.inf for a singular matrix. ``factored`` may pass lu_factor(A) to reuse it.
    """
    try:
        factored = factored or lu_factor(matrix)
    except Singular:
        return math.inf
    n = len(matrix)
    inverse_norm = 0.0
    for j in range(n):
        column = lu_solve(factored, [1.0 if i == j else 0.0 for i in range(n)])
        inverse_norm = max(inverse_norm, sum(abs(v) for v in column))
    if not math.isfinite(inverse_norm):
        return math.inf
    return one_norm(matrix) * inverse_norm
