"""Compiled kernels of a planar.Mechanism: the solver's hot path as straight-line code (stdlib).

planar.py assembles Phi, Phi_q and gamma joint by joint into dense lists and factors the
9 x 9 Jacobian by generic Gaussian elimination: clear, general, and about 250 us per
communication step in CPython, almost all of it interpreter overhead (method calls, tuple
building, loops over structural zeros). A planar Jacobian is sparse (a revolute row has
three or four non-zeros) and its pattern never changes, so this module writes, once per
mechanism, Python source for

- the scaled residual Phi(q), the non-zeros of the scaled Jacobian Phi_q(q) and gamma(q, q');
- an LU factorisation of Phi_q for one fixed row order (the pivots partial pivoting chose at
  some configuration), with its fill-in worked out symbolically: only the operations on
  structural non-zeros remain, as arithmetic on local variables;
- the forward and back substitutions with L U and with their transpose (for the condition
  estimate), and the sign of det(Phi_q).

and compiles it with ``compile``/``exec``. Partial pivoting is kept in effect: the factor
returns None when a fixed pivot is smaller than half of another candidate in its column
(multipliers stay <= 2), and the caller compiles (and caches) the kernel of the row order
partial pivoting chooses at the current configuration. Every number the kernels compute is
the same expression planar.py evaluates, up to rounding.

The condition number is estimated as LAPACK's xGECON does (Hager's method as refined by
Higham: a lower bound of ||A^-1||_1 that is exact unless the matrix is contrived), started
from the column that gave the maximum at the previous step, so along a motion it costs one
solve with A and one with A^T.
"""

import math
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

from ..numerics.linalg import Singular, lu_factor

# planar.GROUND: the ground is body None. This module imports nothing of planar.py (which
# imports it): a joint names the form its kernel takes in its ``kernel`` attribute.
GROUND = None


Drive = Sequence[Sequence[float]]  # per driver: (value, rate, second derivative)
Factors = tuple[Any, ...]  # an LU kernel's factors, the sign of det(A) last


class Unsupported(Exception):
    """The mechanism has a joint type this compiler does not know (use planar.py's path)."""


def _num(value: float) -> str:
    return repr(float(value))


def _sum(terms: Sequence[tuple[float, str]]) -> str:
    """Source of a sum of (coefficient, expression) terms; zero coefficients dropped."""
    parts = []
    for coefficient, expression in terms:
        if coefficient == 0.0:
            continue
        if coefficient == 1.0:
            parts.append(f"+ {expression}")
        elif coefficient == -1.0:
            parts.append(f"- {expression}")
        else:
            parts.append(f"+ {_num(coefficient)} * {expression}")
    if not parts:
        return "0.0"
    text = " ".join(parts)
    return "(" + text.removeprefix("+ ") + ")"


class _Body:
    """Source names of one body's coordinates, trigonometry and rates (ground: constants)."""

    def __init__(self, body: Any) -> None:
        self.ground = body is GROUND
        self.index: int | None = None if self.ground else body
        b = body
        self.x, self.y, self.phi = (
            (f"x{b}", f"y{b}", f"p{b}") if not self.ground else ("0.0", "0.0", "0.0")
        )
        self.c, self.s = (f"c{b}", f"s{b}") if not self.ground else ("1.0", "0.0")
        self.vx, self.vy, self.w = (
            (f"vx{b}", f"vy{b}", f"w{b}") if not self.ground else ("0.0", "0.0", "0.0")
        )

    def rotate(self, local: Sequence[float]) -> tuple[str, str]:
        """Source of A(phi) local, (x, y)."""
        lx, ly = float(local[0]), float(local[1])
        if self.ground:
            return _num(lx), _num(ly)
        return (_sum([(lx, self.c), (-ly, self.s)]), _sum([(lx, self.s), (ly, self.c)]))

    def point(self, local: Sequence[float]) -> tuple[str, str]:
        ax, ay = self.rotate(local)
        if self.ground:
            return ax, ay
        return f"({self.x} + {ax})", f"({self.y} + {ay})"

    def column(self, coordinate: int) -> int:
        assert self.index is not None  # called for moving bodies only (code generation)
        return 3 * self.index + coordinate


class _Emitter:
    """Source lines and Jacobian entries of every joint of a mechanism, in row order."""

    def __init__(self, mechanism: Any) -> None:
        self.residual: list[str] = []  # statements
        self.jacobian: list[str] = []
        self.gamma: list[str] = []
        self.residual_rows: list[str] = []  # one expression per row
        self.gamma_rows: list[str] = []
        self.entries: dict[tuple[int, int], list[str]] = {}  # (row, column) -> [expression terms]
        self.rate_rows: dict[int, int] = {}  # row -> drive index (velocity right-hand side)
        row = 0
        for k, joint in enumerate(mechanism.joints):
            emit = _JOINTS.get(type(joint).__dict__.get("kernel", ""))
            if emit is None:
                raise Unsupported(type(joint).__name__)
            emit(self, k, row, joint)
            row += joint.equations

    def entry(self, row: int, column: int, expression: str) -> None:
        self.entries.setdefault((row, column), []).append(expression)


def _revolute(e: _Emitter, k: int, row: int, joint: Any) -> None:
    bi, bj = _Body(joint.body_i), _Body(joint.body_j)
    pix, piy = bi.point(joint.point_i)
    pjx, pjy = bj.point(joint.point_j)
    e.residual_rows += [f"{pix} - {pjx}", f"{piy} - {pjy}"]
    gx: list[str] = []
    gy: list[str] = []
    for body, local, sign, tag in ((bi, joint.point_i, 1.0, "i"), (bj, joint.point_j, -1.0, "j")):
        if body.ground:
            continue
        ax, ay = body.rotate(local)
        name = f"r{k}{tag}"
        e.jacobian.append(f"{name}x = {ax}; {name}y = {ay}")
        e.gamma.append(f"{name}x = {ax}; {name}y = {ay}")
        e.entry(row, body.column(0), _num(sign))
        e.entry(row + 1, body.column(1), _num(sign))
        # d/dphi A s = perp(A s) = (-ay, ax)
        e.entry(row, body.column(2), f"{_num(-sign)} * {name}y")
        e.entry(row + 1, body.column(2), f"{_num(sign)} * {name}x")
        w2 = f"{body.w} * {body.w}"
        gx.append(f"{_num(sign)} * {name}x * {w2}")
        gy.append(f"{_num(sign)} * {name}y * {w2}")
    e.gamma_rows += [" + ".join(gx) or "0.0", " + ".join(gy) or "0.0"]


def _point_on_line_on_ground(e: _Emitter, k: int, row: int, joint: Any) -> None:
    """A point of a body on a fixed line: the normal is a constant, folded into the code
    (a zero component drops its Jacobian entry)."""
    bi = _Body(joint.body_i)
    nx, ny = float(joint.normal_j[0]), float(joint.normal_j[1])
    pix, piy = bi.point(joint.point_i)
    pjx, pjy = _num(joint.point_j[0]), _num(joint.point_j[1])
    aix, aiy = bi.rotate(joint.point_i)
    e.residual_rows.append(_sum([(nx, f"({pix} - {pjx})"), (ny, f"({piy} - {pjy})")]))
    e.jacobian.append(f"a{k}ix = {aix}; a{k}iy = {aiy}")
    e.gamma.append(f"a{k}ix = {aix}; a{k}iy = {aiy}")
    for coordinate, value in ((0, nx), (1, ny)):
        if value != 0.0:
            e.entry(row, bi.column(coordinate), _num(value))
    # n . perp(a_i) = n_y a_ix - n_x a_iy; gamma = n . a_i w_i^2
    e.entry(row, bi.column(2), _sum([(ny, f"a{k}ix"), (-nx, f"a{k}iy")]))
    e.gamma_rows.append(f"{_sum([(nx, f'a{k}ix'), (ny, f'a{k}iy')])} * {bi.w} * {bi.w}")


def _point_on_line(e: _Emitter, k: int, row: int, joint: Any) -> None:
    if joint.body_j is GROUND and joint.body_i is not GROUND:
        _point_on_line_on_ground(e, k, row, joint)
        return
    bi, bj = _Body(joint.body_i), _Body(joint.body_j)
    nx, ny = bj.rotate(joint.normal_j)
    pix, piy = bi.point(joint.point_i)
    pjx, pjy = bj.point(joint.point_j)
    aix, aiy = bi.rotate(joint.point_i)
    ajx, ajy = bj.rotate(joint.point_j)
    parts = (
        f"n{k}x = {nx}; n{k}y = {ny}; d{k}x = {pix} - {pjx}; d{k}y = {piy} - {pjy}; "
        f"a{k}ix = {aix}; a{k}iy = {aiy}; a{k}jx = {ajx}; a{k}jy = {ajy}"
    )
    e.residual.append(f"n{k}x = {nx}; n{k}y = {ny}")
    e.residual_rows.append(f"n{k}x * ({pix} - {pjx}) + n{k}y * ({piy} - {pjy})")
    e.jacobian.append(parts)
    n = (f"n{k}x", f"n{k}y")
    if not bi.ground:
        e.entry(row, bi.column(0), n[0])
        e.entry(row, bi.column(1), n[1])
        # n . perp(a_i) = -n_x a_iy + n_y a_ix
        e.entry(row, bi.column(2), f"(n{k}y * a{k}ix - n{k}x * a{k}iy)")
    if not bj.ground:
        e.entry(row, bj.column(0), f"-{n[0]}")
        e.entry(row, bj.column(1), f"-{n[1]}")
        # perp(n) . d - n . perp(a_j), perp(n) = (-n_y, n_x)
        e.entry(
            row,
            bj.column(2),
            f"(n{k}x * d{k}y - n{k}y * d{k}x - (n{k}y * a{k}jx - n{k}x * a{k}jy))",
        )
    wi, wj = bi.w, bj.w
    e.gamma.append(parts)
    # ddot = v_i + perp(a_i) w_i - v_j - perp(a_j) w_j; centripetal = a_i w_i^2 - a_j w_j^2
    e.gamma.append(
        f"dd{k}x = {bi.vx} - a{k}iy * {wi} - {bj.vx} + a{k}jy * {wj}; "
        f"dd{k}y = {bi.vy} + a{k}ix * {wi} - {bj.vy} - a{k}jx * {wj}"
    )
    e.gamma.append(
        f"ce{k}x = a{k}ix * {wi} * {wi} - a{k}jx * {wj} * {wj}; "
        f"ce{k}y = a{k}iy * {wi} * {wi} - a{k}jy * {wj} * {wj}"
    )
    e.gamma_rows.append(
        f"(n{k}x * d{k}x + n{k}y * d{k}y) * {wj} * {wj}"
        f" - 2.0 * {wj} * (n{k}x * dd{k}y - n{k}y * dd{k}x)"
        f" + n{k}x * ce{k}x + n{k}y * ce{k}y"
    )


def _relative_angle(e: _Emitter, k: int, row: int, joint: Any) -> None:
    bi, bj = _Body(joint.body_i), _Body(joint.body_j)
    e.residual_rows.append(f"{bi.phi} - {bj.phi} - {_num(joint.angle)}")
    if not bi.ground:
        e.entry(row, bi.column(2), "1.0")
    if not bj.ground:
        e.entry(row, bj.column(2), "-1.0")
    e.gamma_rows.append("0.0")


def _driver(e: _Emitter, k: int, row: int, joint: Any) -> None:
    terms = [(weight, f"q[{3 * body + coordinate}]") for body, coordinate, weight in joint.terms]
    e.residual_rows.append(f"{_num(joint.offset)} + {_sum(terms)} - d[{joint.index}][0]")
    for body, coordinate, weight in joint.terms:
        e.entry(row, 3 * body + coordinate, _num(weight))
    e.rate_rows[row] = joint.index
    e.gamma_rows.append(f"d[{joint.index}][2]")


# the emitter of each joint's ``kernel`` form (planar.Revolute, PointOnLine, RelativeAngle,
# Driver); a joint class that names none (a subclass included) takes planar.py's path
_JOINTS: dict[str, Callable[[_Emitter, int, int, Any], None]] = {
    "revolute": _revolute,
    "point_on_line": _point_on_line,
    "relative_angle": _relative_angle,
    "driver": _driver,
}


def _unpack(size: int, rates: bool = False) -> list[str]:
    names = [f"{v}{b}" for b in range(size // 3) for v in ("x", "y", "p")]
    lines = [f"    {', '.join(names)}, = q"]
    if rates:
        rate_names = [f"{v}{b}" for b in range(size // 3) for v in ("vx", "vy", "w")]
        lines.append(f"    {', '.join(rate_names)}, = qd")
    for b in range(size // 3):
        lines.append(f"    c{b} = cos(p{b}); s{b} = sin(p{b})")
    return lines


class KernelSources(NamedTuple):
    """Source pieces of a mechanism's kernels (lines indented for a function body), for
    the LU kernels' fused functions: unpacking q (and q'), the statements and the
    expressions of the residual, the Jacobian's varying entries and gamma."""

    unpack: list[str]
    unpack_rates: list[str]
    residual: list[str]
    residual_jacobian: list[str]
    gamma: list[str]
    residual_list: str
    entries: str
    gamma_list: str
    one_norm: str = "0.0"  # of the Jacobian's varying entries v[m]


class MechanismKernel:
    """The compiled residual, Jacobian, gamma and velocity right-hand side of a mechanism,
    and its LU kernels by row order (``factor``)."""

    def __init__(self, mechanism: Any) -> None:
        e = _Emitter(mechanism)
        n = self.size = mechanism.size
        rs, cs = mechanism.row_scale, mechanism.column_scale
        self.column_scale = tuple(cs)
        # Entries that do not depend on q (a driver's weight, a joint's +-1 on x and y, an
        # attachment at a body's origin) are worked out here and folded into the LU
        # kernels' code; identically zero ones are dropped from the pattern. The Jacobian
        # functions return the other entries, in ``pattern`` order.
        scaled = {
            key: f"({' + '.join(e.entries[key])}) * {_num(rs[key[0]] * cs[key[1]])}"
            for key in sorted(e.entries)
        }
        known = _known_locals(e.jacobian)
        fixed = {key: _constant(expression, known) for key, expression in scaled.items()}
        self.constants = {
            key: value for key, value in fixed.items() if value is not None and value != 0.0
        }
        self.pattern = [key for key, value in fixed.items() if value is None]
        entries = ", ".join(scaled[key] for key in self.pattern)
        namespace: dict[str, Any] = {"cos": math.cos, "sin": math.sin}
        residual_list = (
            "["
            + ", ".join(f"({expr}) * {_num(rs[i])}" for i, expr in enumerate(e.residual_rows))
            + "]"
        )
        gamma_list = (
            "["
            + ", ".join(f"({expr}) * {_num(rs[i])}" for i, expr in enumerate(e.gamma_rows))
            + "]"
        )
        # The pieces the LU kernels splice into their fused functions (LuKernel, sources).
        self.sources = KernelSources(
            unpack=_unpack(n),
            unpack_rates=_unpack(n, rates=True),
            residual=[f"    {s}" for s in e.residual],
            residual_jacobian=[f"    {s}" for s in e.residual + e.jacobian],
            gamma=[f"    {s}" for s in e.gamma],
            residual_list=residual_list,
            entries=f"({entries},)" if entries else "()",
            gamma_list=gamma_list,
        )
        lines = ["def residual(q, d):", *_unpack(n)]
        lines += [f"    {s}" for s in e.residual]
        lines.append(
            "    return ["
            + ", ".join(f"({expr}) * {_num(rs[i])}" for i, expr in enumerate(e.residual_rows))
            + "]"
        )
        lines += ["def jacobian(q):", *_unpack(n)]
        lines += [f"    {s}" for s in e.jacobian]
        lines.append(f"    return ({entries},)" if entries else "    return ()")
        lines += ["def predict(q, v, a, vb, ab, cv, ca, ka, kb):"]
        lines += [
            f"    return [{', '.join(f'q[{j}] + cv * v[{j}] + ca * a[{j}] + ka * ab[{j}] + kb * vb[{j}]' for j in range(n))}]"
        ]
        # predict with its coefficients from the step dt and the last step h (see
        # planar.BranchFollower._fast_guess for their derivation)
        lines += [
            "def predict_step(q, v, a, vb, ab, dt, h):",
            "    c3 = dt**3 / 6.0; c4 = dt**4 / 24.0",
            "    ka = 2.0 * c3 / h + 6.0 * c4 / (h * h)",
            "    kb = 6.0 * c3 / (h * h) + 12.0 * c4 / h**3",
            "    cv = dt - kb; ca = 0.5 * dt * dt - ka + kb * h",
            lines[-1],
        ]
        lines += ["def residual_jacobian(q, d):", *_unpack(n)]
        lines += [f"    {s}" for s in e.residual + e.jacobian]
        lines.append(
            "    return ["
            + ", ".join(f"({expr}) * {_num(rs[i])}" for i, expr in enumerate(e.residual_rows))
            + "], ("
            + (f"{entries}," if entries else "")
            + ")"
        )
        lines += ["def gamma(q, qd, d):", *_unpack(n, rates=True)]
        lines += [f"    {s}" for s in e.gamma]
        lines.append(
            "    return ["
            + ", ".join(f"({expr}) * {_num(rs[i])}" for i, expr in enumerate(e.gamma_rows))
            + "]"
        )
        columns: dict[int, list[str]] = {}
        for m, (_, j) in enumerate(self.pattern):
            columns.setdefault(j, []).append(f"abs(v[{m}])")
        fixed_sums: dict[int, float] = {}
        for (_, j), value in sorted(self.constants.items()):
            fixed_sums[j] = fixed_sums.get(j, 0.0) + abs(value)
        for j, total in fixed_sums.items():
            columns.setdefault(j, []).append(_num(total))
        sums = [" + ".join(terms) for terms in columns.values()] or ["0.0"]
        norm = f"max({', '.join(sums)})" if len(sums) > 1 else sums[0]
        lines += ["def one_norm(v):", f"    return {norm}"]
        self.sources = self.sources._replace(one_norm=norm)
        lines += [
            "def rates(d):",
            "    return ["
            + ", ".join(
                f"d[{e.rate_rows[i]}][1] * {_num(rs[i])}" if i in e.rate_rows else "0.0"
                for i in range(n)
            )
            + "]",
        ]
        source = "\n".join(lines) + "\n"  # generated here from the joints, nothing read in
        exec(compile(source, f"<{mechanism.name} kernel>", "exec"), namespace)  # noqa: S102
        # The generated functions (their signatures are the ``def`` lines above).
        self.residual: Callable[[Sequence[float], Drive], list[float]] = namespace["residual"]
        self.jacobian: Callable[[Sequence[float]], tuple[float, ...]] = namespace["jacobian"]
        self.gamma: Callable[[Sequence[float], Sequence[float], Drive], list[float]] = namespace[
            "gamma"
        ]
        self.rates: Callable[[Drive], list[float]] = namespace["rates"]
        self.residual_jacobian: Callable[
            [Sequence[float], Drive], tuple[list[float], tuple[float, ...]]
        ] = namespace["residual_jacobian"]
        # the fast path's predictor, unrolled
        self.predict: Callable[..., list[float]] = namespace["predict"]
        self.predict_step: Callable[..., list[float]] = namespace["predict_step"]
        # 1-norm of the scaled Jacobian's non-zeros
        self.one_norm: Callable[[Sequence[float]], float] = namespace["one_norm"]
        self.orders: dict[tuple[int, ...], LuKernel] = {}

    def dense(self, values: Sequence[float]) -> list[list[float]]:
        """The scaled Jacobian as a dense list of rows, from jacobian()'s non-zeros."""
        matrix = [[0.0] * self.size for _ in range(self.size)]
        for (i, j), v in self.constants.items():
            matrix[i][j] = v
        for (i, j), v in zip(self.pattern, values):
            matrix[i][j] = v
        return matrix

    def lu(self, order: tuple[int, ...]) -> "LuKernel":
        """The LuKernel for row order ``order`` (compiled once, then cached)."""
        kernel = self.orders.get(order)
        if kernel is None:
            kernel = self.orders[order] = LuKernel(
                self.pattern, self.size, order, self.column_scale, self.constants, self.sources
            )
        return kernel

    def factor(
        self, values: Sequence[float], order: tuple[int, ...] | None = None
    ) -> "tuple[LuKernel, Factors] | None":
        """The LU kernel and factors of the scaled Jacobian ``values`` (jacobian()'s
        non-zeros): in row order ``order`` while its pivots stay within a factor 2 of their
        columns' largest, else in the order partial pivoting chooses here. None if the
        matrix is singular."""
        if order is not None:
            lu = self.lu(order)
            factors = lu.factor(values)
            if factors is not None:
                return lu, factors
        try:
            _, pivots = lu_factor(self.dense(values))
            lu = self.lu(tuple(pivots))
        except (Singular, ZeroDivisionError):
            return None
        factors = lu.factor(values)
        return None if factors is None else (lu, factors)

    def condition(
        self, lu: "LuKernel", factors: Factors, values: Sequence[float], column: int | None
    ) -> tuple[float, int]:
        """(1-norm condition estimate of the scaled Jacobian ``values`` factored as
        ``factors``, the column of its inverse that attains it): one Hager step from
        ``column`` (the last call's) when that settles it, else inverse_one_norm."""
        condition = None if column is None else lu.condition(factors, values, column)
        if condition is not None:
            return condition, column  # type: ignore[return-value]  # column is set here
        inverse_norm, column = inverse_one_norm(lu, factors, self.size, column)
        return self.one_norm(values) * inverse_norm, column


# MechanismKernel by mechanism shape, for every instance of the process (a FourBar's kernels
# take milliseconds to write and compile: per step of a 2000-step run about what the step
# itself costs; a sweep or a re-instantiated FMU builds the same mechanism again).
KERNEL_CACHE_SIZE = 32  # shapes kept, the oldest dropped first (a sweep over geometries)
_KERNELS: dict[tuple, "MechanismKernel"] = {}


def mechanism_shape(mechanism: Any) -> tuple | None:
    """What a mechanism's generated code depends on: its name (the code's file name in a
    traceback), each joint's class and attributes but its name (bodies, local points, line
    normals, angles, driver terms), the row and column scales; None when an attribute is
    not hashable (such a mechanism is not cached)."""
    joints = tuple(
        (type(joint), tuple(sorted((k, v) for k, v in vars(joint).items() if k != "name")))
        for joint in mechanism.joints
    )
    shape = (mechanism.name, joints, tuple(mechanism.row_scale), tuple(mechanism.column_scale))
    try:
        hash(shape)
    except TypeError:
        return None
    return shape


def mechanism_kernel(mechanism: Any) -> "MechanismKernel":
    """The MechanismKernel of ``mechanism``, built once per mechanism shape in this process
    (mechanism_shape) and shared: its functions and its LU kernels by row order are pure.
    Unsupported as MechanismKernel."""
    shape = mechanism_shape(mechanism)
    kernel = _KERNELS.get(shape) if shape is not None else None
    if kernel is None:
        kernel = MechanismKernel(mechanism)
        if shape is not None:
            if len(_KERNELS) >= KERNEL_CACHE_SIZE:
                del _KERNELS[next(iter(_KERNELS))]
            _KERNELS[shape] = kernel
    return kernel


def _known_locals(statements: Sequence[str]) -> dict[str, float]:
    """The locals of generated ``name = expression; ...`` statements whose value does not
    depend on q (their expressions use only numbers and such locals), with their values."""
    known: dict[str, float] = {}
    for statement in statements:
        for assignment in statement.split("; "):
            name, _, expression = assignment.partition(" = ")
            value = _constant(expression, known)
            if value is not None:
                known[name.strip()] = value
    return known


def _constant(expression: str, known: dict[str, float]) -> float | None:
    """The value of a generated expression if it uses only numbers and ``known`` locals
    (the same float arithmetic the compiled code would do), else None."""
    try:
        # generated here from the joints, nothing read in; no builtins
        return float(eval(expression, {"__builtins__": {}}, dict(known)))  # noqa: S307
    except NameError:
        return None


Value = float | str  # an entry while the LU is written: a number known now, or a local's name


def _times(x: Value, y: Value) -> tuple[float, str] | float:
    """x * y as a number (both known), or (c, expression) for c * expression."""
    if isinstance(x, float) and isinstance(y, float):
        return x * y
    if isinstance(x, float):
        return 0.0 if x == 0.0 else (x, str(y))
    if isinstance(y, float):
        return 0.0 if y == 0.0 else (y, x)
    return (1.0, f"{x} * {y}")


def _minus_term(product: tuple[float, str] | float) -> str:
    """Source of `` - product`` (empty for a zero): - c * expression, the same number as
    the product the unfolded code subtracts."""
    if isinstance(product, float):
        return "" if product == 0.0 else f" - {_num(product)}"
    c, expression = product
    if c == 1.0:
        return f" - {expression}"
    if c == -1.0:  # x - (-1 * y) is x + y exactly
        return f" + {expression}"
    return f" - {_num(c)} * {expression}"


def _over(expression: str, divisor: Value) -> str:
    """Source of (expression) / divisor; 1 and -1 folded (exact)."""
    if divisor == 1.0:
        return expression
    if divisor == -1.0:
        return f"-({expression})"
    return f"({expression}) / {divisor if isinstance(divisor, str) else _num(divisor)}"


class LuKernel:
    """Sparse LU of one row order: ``factor(values)`` -> F or None (a pivot too small against
    another candidate of its column); ``solve(F, b)``, ``solve_t(F, c)`` (A^T x = c);
    ``sign(F)``: sign of det(A).

    ``pattern`` lists the (row, column) of the entries ``factor`` reads, in order;
    ``constants`` the entries known when the kernel is written, {(row, column): value}.
    Arithmetic on known numbers is done here, products with 1 and -1 are folded, so the code
    left holds only the operations on entries that vary; every result is the one the
    unfolded elimination gives, bit for bit (x - (-1 y) = x + y, c * y = y * c)."""

    def __init__(
        self,
        pattern: Sequence[tuple[int, int]],
        n: int,
        order: tuple[int, ...],
        scale: Sequence[float],
        constants: dict[tuple[int, int], float] | None = None,
        sources: KernelSources | None = None,
    ) -> None:
        self.order = order
        position = {row: k for k, row in enumerate(order)}  # original row -> position
        # a[(i, j)]: entry (i, j) of P A during the elimination: a number known here, or
        # the name of the local that holds it (always a{i}_{j})
        a: dict[tuple[int, int], Value] = {}
        lines = ["def factor(v):"]
        for m, (i, j) in enumerate(pattern):
            lines.append(f"    a{position[i]}_{j} = v[{m}]")
            a[position[i], j] = f"a{position[i]}_{j}"
        for (i, j), value in (constants or {}).items():
            a[position[i], j] = float(value)

        def text(value: Value) -> str:
            return value if isinstance(value, str) else _num(value)

        multipliers: list[tuple[int, int]] = []
        upper: list[tuple[int, int]] = []
        for k in range(n):
            if (k, k) not in a:
                raise ZeroDivisionError("structurally singular for this row order")
            pivot = a[k, k]
            below = [i for i in range(k + 1, n) if (i, k) in a]
            right = [j for j in range(k + 1, n) if (k, j) in a]
            for i in below:
                other = a[i, k]
                if isinstance(pivot, float) and isinstance(other, float):
                    if pivot * pivot < 0.25 * other * other:
                        lines.append("    return None")
                else:
                    p, o = text(pivot), text(other)
                    lines.append(f"    if {p} * {p} < 0.25 * {o} * {o}: return None")
            if not below:
                if isinstance(pivot, str):
                    lines.append(f"    if {pivot} == 0.0: return None")
                elif pivot == 0.0:
                    lines.append("    return None")
            for i in below:
                name, other = f"a{i}_{k}", a[i, k]
                if isinstance(other, float) and isinstance(pivot, float):
                    a[i, k] = other / pivot
                elif pivot != 1.0:
                    lines.append(f"    {name} = {_over(text(other), pivot)}")
                    a[i, k] = name
                multipliers.append((i, k))
                for j in right:
                    product = _times(a[i, k], a[k, j])
                    target = f"a{i}_{j}"
                    current = a.get((i, j))
                    if current is None:  # fill-in: -(a_ik a_kj)
                        if isinstance(product, float):
                            a[i, j] = -product
                            continue
                        c, expression = product
                        if c == 1.0:
                            source = f"-{expression}"
                        elif c == -1.0:
                            source = expression
                        else:
                            source = f"{_num(-c)} * {expression}"
                    elif isinstance(current, float) and isinstance(product, float):
                        a[i, j] = current - product
                        continue
                    else:
                        change = _minus_term(product)
                        if not change:
                            continue
                        source = text(current) + change
                    lines.append(f"    {target} = {source}")
                    a[i, j] = target
            upper += [(k, j) for j in [k] + right]
        names = [f"a{i}_{j}" for i, j in multipliers + upper if isinstance(a[i, j], str)]
        diagonal = [a[k, k] for k in range(n)]
        varying = [d for d in diagonal if isinstance(d, str)]
        if varying:
            lines.append(f"    if not isfinite({' + '.join(varying)}): return None")
        fixed_negative = sum(1 for d in diagonal if isinstance(d, float) and d < 0.0)
        counted = [f"({d} < 0.0)" for d in varying] + [str(fixed_negative)]
        parity = _parity(order)
        lines.append(f"    negative = {' + '.join(counted)}")
        lines.append(
            f"    return ({', '.join(names + [f'{parity} if negative % 2 == 0 else {-parity}'])},)"
        )
        unpack = f"    {', '.join(names + ['_'])}, = F"
        lower_of = {i: [k for (r, k) in multipliers if r == i] for i in range(n)}
        upper_of = {k: [j for (r, j) in upper if r == k and j != k] for k in range(n)}

        def minus(i: int, j: int, unknown: str) -> str:
            return _minus_term(_times(a[i, j], unknown))

        # A = P^T L U with row k of P A being original row order[k].
        lines += ["def solve(F, b):", unpack]
        for i in range(n):
            terms = "".join(minus(i, k, f"y{k}") for k in lower_of[i])
            lines.append(f"    y{i} = b[{order[i]}]{terms}")
        for k in range(n - 1, -1, -1):
            terms = "".join(minus(k, j, f"y{j}") for j in upper_of[k])
            lines.append(f"    y{k} = {_over(f'y{k}{terms}', a[k, k])}")
        lines.append(f"    return [{', '.join(f'y{j}' for j in range(n))}]")
        body = lines[lines.index("def solve(F, b):") + 1 : -1]
        # The same substitutions, the solution scaled by ``scale`` (the coordinates of a
        # scaled system), and a Newton correction q - scale x with max |x|.
        lines += [
            "def solve_scaled(F, b):",
            *body,
            f"    return [{', '.join(f'y{j} * {scale[j]!r}' for j in range(n))}]",
        ]
        corrected = ", ".join(f"q[{j}] - y{j} * {scale[j]!r}" for j in range(n))
        largest = ", ".join(f"abs(y{j})" for j in range(n))
        lines += ["def correct(F, b, q):", *body, f"    return ([{corrected}], max({largest}))"]
        # The final correction and the velocity: two right-hand sides, one unpacking.
        second = [line.replace("y", "v").replace("b[", "r[") for line in body[1:]]
        velocity = ", ".join(f"v{j} * {scale[j]!r}" for j in range(n))
        lines += [
            "def correct_and_solve(F, b, q, r):",
            *body,
            *second,
            f"    return [{corrected}], max({largest}), [{velocity}]",
        ]
        # A^T x = c: U^T w = c, L^T z = w, x[order[k]] = z[k].
        lines += ["def solve_t(F, c):", unpack]
        upper_col = {j: [k for (k, jj) in upper if jj == j and k != j] for j in range(n)}
        lower_col = {k: [i for (i, kk) in multipliers if kk == k] for k in range(n)}
        for j in range(n):
            terms = "".join(minus(k, j, f"w{k}") for k in upper_col[j])
            lines.append(f"    w{j} = {_over(f'c[{j}]{terms}', a[j, j])}")
        for k in range(n - 1, -1, -1):
            terms = "".join(minus(i, k, f"w{i}") for i in lower_col[k])
            if terms:
                lines.append(f"    w{k} = w{k}{terms}")
        inverse = [0] * n
        for k, row in enumerate(order):
            inverse[row] = k
        lines.append(f"    return [{', '.join(f'w{inverse[r]}' for r in range(n))}]")
        transposed = lines[lines.index("def solve_t(F, c):") + 2 :]
        # One step of Hager's estimator: y = A^-1 x, its 1-norm, and z = A^-T sign(y).
        lines += [
            "def hager_step(F, b):",
            *body,
            f"    c = ({', '.join(f'1.0 if y{j} >= 0.0 else -1.0' for j in range(n))},)",
            *transposed[:-1],
            f"    return {' + '.join(f'abs(y{j})' for j in range(n))}, "
            + transposed[-1].strip()[len("return ") :],
        ]
        if sources is not None:
            hager_body = lines[lines.index("def hager_step(F, b):") + 1 :]
            lines += _fused(sources, body, hager_body, scale, n)
        namespace: dict[str, Any] = {"isfinite": math.isfinite, "cos": math.cos, "sin": math.sin}
        source = "\n".join(lines) + "\n"  # generated here from the pattern, nothing read in
        exec(compile(source, "<planar LU kernel>", "exec"), namespace)  # noqa: S102
        # The generated functions; F, factor()'s result, is a tuple (the factors, then the
        # sign of det(A)).
        self.factor: Callable[[Sequence[float]], Factors | None] = namespace["factor"]
        self.solve: Callable[[Factors, Sequence[float]], list[float]] = namespace["solve"]
        self.solve_t: Callable[[Factors, Sequence[float]], list[float]] = namespace["solve_t"]
        self.hager_step: Callable[[Factors, Sequence[float]], tuple[float, list[float]]] = (
            namespace["hager_step"]
        )
        self.solve_scaled: Callable[[Factors, Sequence[float]], list[float]] = namespace[
            "solve_scaled"
        ]
        self.correct: Callable[
            [Factors, Sequence[float], Sequence[float]], tuple[list[float], float]
        ] = namespace["correct"]
        self.correct_and_solve: Callable[
            [Factors, Sequence[float], Sequence[float], Sequence[float]],
            tuple[list[float], float, list[float]],
        ] = namespace["correct_and_solve"]

        # With the mechanism's sources (MechanismKernel.lu): one Newton (or chord)
        # correction with these factors and the residual and Jacobian after it, and the
        # acceleration, each one call (see _fused).
        self.newton_step: Callable[
            [Factors, Sequence[float], Drive],
            tuple[list[float], float, list[float], tuple[float, ...], float],
        ] = namespace.get("newton_step", _no_sources)
        self.condition: Callable[[Factors, Sequence[float], int], float | None] = namespace.get(
            "condition", _no_sources
        )
        self.acceleration: Callable[
            [Factors, Sequence[float], Sequence[float], Drive], list[float]
        ] = namespace.get("acceleration", _no_sources)

    @staticmethod
    def sign(F: Factors) -> int:
        """Sign of det(A) from factor()'s result."""
        return F[-1]


def _no_sources(*args: Any) -> Any:
    raise TypeError("this LuKernel was built without the mechanism's sources")


def _fused(
    sources: KernelSources,
    body: list[str],
    hager_body: list[str],
    scale: Sequence[float],
    n: int,
) -> list[str]:
    """Source of the fused functions of an LU kernel: ``body`` is its solve (F unpacked,
    unknowns y0.., right-hand side b), renamed u0.. here (y0 is a coordinate's name).

    newton_step(F, q, d): the residual at q, the correction q - scale A^-1 residual and its
    largest |x|, then the residual, the Jacobian's varying entries and the largest |residual|
    at the corrected q: what solve_position's iteration needs, in one call.
    acceleration(F, q, qd, d): q'' = scale A^-1 gamma(q, q', d).
    condition(F, v, column): the 1-norm condition estimate ||A||_1 est(||A^-1||_1) of
    inverse_one_norm started from e_column, when its first Hager step already settles it
    (the usual case along a motion); None otherwise (then inverse_one_norm decides).
    The same expressions as residual, correct, residual_jacobian, gamma and solve_scaled."""
    solve = [line.replace("y", "u") for line in body[1:]]
    corrected = ", ".join(f"q[{j}] - u{j} * {scale[j]!r}" for j in range(n))
    largest = ", ".join(f"abs(u{j})" for j in range(n))
    # from b: y = A^-1 b, then w = A^-T sign(y), the signs written where c[j] is read
    hager = []
    for line in hager_body[1:-1]:
        if line.startswith("    c = ("):
            continue
        for j in range(n):
            line = line.replace(f"c[{j}]", f"(1.0 if y{j} >= 0.0 else -1.0)")
        hager.append(line)
    z = hager_body[-1].strip()[len("return ") :].split(", ", 1)[1]  # the list of A^-T c
    return [
        "def condition(F, v, column):",
        body[0],
        f"    b = [0.0] * {n}",
        "    b[column] = 1.0",
        *hager,
        f"    value = {' + '.join(f'abs(y{j})' for j in range(n))}",
        f"    z = {z}",
        "    magnitudes = list(map(abs, z))",
        "    best = magnitudes.index(max(magnitudes))",
        "    if value > 0.0 and (best == column or magnitudes[best] <= z[column]):",
        f"        return {sources.one_norm} * value",
        "    return None",
        "def newton_step(F, q, d):",
        body[0],
        *sources.unpack,
        *sources.residual,
        f"    b = {sources.residual_list}",
        *solve,
        f"    q = [{corrected}]",
        f"    correction = max({largest})",
        *sources.unpack,
        *sources.residual_jacobian,
        f"    r = {sources.residual_list}",
        f"    return q, correction, r, {sources.entries}, max(map(abs, r))",
        "def acceleration(F, q, qd, d):",
        body[0],
        *sources.unpack_rates,
        *sources.gamma,
        f"    b = {sources.gamma_list}",
        *solve,
        f"    return [{', '.join(f'u{j} * {scale[j]!r}' for j in range(n))}]",
    ]


def _parity(order: Sequence[int]) -> int:
    """+1 for an even permutation, -1 for an odd one."""
    seen, sign = [False] * len(order), 1
    for start in range(len(order)):
        length, j = 0, start
        while not seen[j]:
            seen[j] = True
            j = order[j]
            length += 1
        if length and length % 2 == 0:
            sign = -sign
    return sign


def inverse_one_norm(
    lu: LuKernel, F: Factors, n: int, start: int | None = None, iterations: int = 5
) -> tuple[float, int]:
    """Estimate of ||A^-1||_1 from the factors (Hager 1984, Higham 1988: LAPACK's xLACON
    without its extra test vector), a lower bound that is exact unless A is contrived. Starts
    from the unit vector e_start (the column that attained the estimate at the previous
    call, along a motion usually still the one), or from (1/n, ..., 1/n) if None. Returns
    (estimate, column): the column of A^-1 that attains it."""
    estimate = 0.0
    if start is None:
        x = [1.0 / n] * n
        column = -1
    else:
        x = [0.0] * n
        x[start] = 1.0
        column = start
    step = lu.hager_step
    for _ in range(iterations):
        value, z = step(F, x)
        if value <= estimate:
            break
        estimate = value
        magnitudes = list(map(abs, z))
        best = magnitudes.index(max(magnitudes))
        # z^T x: x is e_column, or (1/n, ..., 1/n) at a cold start
        along = z[column] if column >= 0 else sum(z) / n
        if best == column or magnitudes[best] <= along:
            break
        column = best
        x = [0.0] * n
        x[best] = 1.0
    return estimate, max(column, 0)
