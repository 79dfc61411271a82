"""Seed-reproduction report: the coursework's numbers recomputed from the numpy references.

``build_report()`` returns Markdown; ``write_report(path)`` writes it. Every number in the
report is computed here. The only numbers typed in are the coursework's inputs (lengths in
ft, stroke speed, k, L, d, masses, g, taken from the physics constants where they exist) and
the coursework's own stated results, which appear only in columns or sentences labelled
"coursework says".
"""

import numpy as np
from pathlib import Path
from typing import Any

from mechfmu.cosim.files import atomic_write
from mechfmu.runtime.physics.landing_gear import COURSEWORK_STROKE_TIME
from mechfmu.runtime.physics.suspension import (
    COURSEWORK_BASE_OFFSET,
    COURSEWORK_FREE_LENGTH,
    COURSEWORK_MASS,
    COURSEWORK_STIFFNESS,
    GRAVITY,
)
from mechfmu.runtime.physics import cam_geometry, cam_laws
from mechfmu.runtime.physics.four_bar import COURSEWORK_CRANK_ANGLE, COURSEWORK_FOUR_BAR, INCH
from mechfmu.runtime.physics.valve_train import DEFAULT_VALVE_GEOMETRY
from mechfmu.runtime.models.shaft_drives import CamshaftDrive
from mechfmu.tools.scene_references import model_defaults
from mechfmu.references import landing_gear as lg
from mechfmu.references import linkages
from mechfmu.references import suspension as sp
from mechfmu.references import valve_train as vt

# Coursework inputs, landing gear (seed 000), in feet as the coursework has them.
RETRACTED_FT = 1.25
EXTENDED_FT = 2.0
TABLE_STEP = 0.25  # s, the report's table spacing
FINE_SAMPLES = 300_001  # grid over [0, T] for maxima (0.01 ms spacing)

# The coursework's own stated values (quoted for comparison only).
SAYS_GEAR = {
    "d": 0.64361,
    "d_2": -1.89361,
    "h": 1.4060,
    "theta_1": 1.0953,
    "theta_1_deg": 62.76,
    "h2+d2": 2.3911,
    "2dh": 1.8098,
    "4dh": 3.6196,
    "dh": 0.9049,
}
SAYS_SUSPENSION: dict[str, Any] = {"h": 0.4583, "u": (0.1375, 0.3804), "kef": (1.5059e4, 5.4410e3)}

# Coursework inputs, suspension (seed 003).
L = COURSEWORK_FREE_LENGTH
K = COURSEWORK_STIFFNESS
D = COURSEWORK_BASE_OFFSET
MASS = COURSEWORK_MASS
G = GRAVITY
NAIVE_EXPONENTS = range(3, 16)  # u = 1e-3 ... 1e-15 m


def _g(value: Any, digits: Any = 6):
    """Compact general format; -0 printed as 0."""
    text = f"{value:.{digits}g}"
    return "0" if text in ("-0", "0") else text


def _f(value: Any, decimals: Any):
    text = f"{value:.{decimals}f}"
    return text[1:] if text.startswith("-") and float(text) == 0.0 else text


def _below(value: Any, bound: Any, unit: str) -> str:
    """'within <bound> <unit>' if value is below bound, else the value itself.

    Keeps rounding-level noise (which varies between platforms) out of the report.
    """
    if value < bound:
        return f"within {bound:.0e} {unit}"
    return f"off by {_g(value, 3)} {unit}"


def _table(header: Any, rows: Any):
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def _constant_speed(t: Any, d: Any, h: Any):
    """Gear motion under the coursework's constant piston speed drive, times t (s)."""
    return lg.retraction(
        t, d, h, RETRACTED_FT, EXTENDED_FT, COURSEWORK_STROKE_TIME, "constant_speed"
    )


def _law_omega_alpha(theta: Any, speed: float, d: Any, h: Any):
    """omega, alpha of the constant-piston-speed law written as functions of theta.

    This is the coursework's eqs. (5)-(6): x from the law of cosines at theta, then
    omega = x xdot / (d h sin theta) and alpha = (xdot^2 - d h cos(theta) omega^2)/(d h sin theta).
    """
    x, _, _ = lg.piston_from_gear(theta, 0.0, 0.0, d, h)
    n = np.size(theta)
    _, omega, alpha = lg.gear_from_piston(x, np.full(n, speed), np.zeros(n), d, h)
    return x, omega, alpha


def _argmax_abs(values: Any, t: Any):
    i = int(np.argmax(np.abs(values)))
    return float(values[i]), float(t[i])


def _landing_gear_section():
    d, h, theta_1 = lg.design_geometry(RETRACTED_FT, EXTENDED_FT)
    T = COURSEWORK_STROKE_TIME
    speed = (EXTENDED_FT - RETRACTED_FT) / T
    roots = np.sort(np.roots([1.0, RETRACTED_FT, 0.5 * (RETRACTED_FT**2 - EXTENDED_FT**2)]).real)
    out = ["## 1. Retractable nose landing gear (seed 000)", ""]
    out += [
        f"Units are the coursework's: ft, rad, s. Piston {_g(RETRACTED_FT)} ft (retracted) "
        f"to {_g(EXTENDED_FT)} ft (extended) in T = {_g(T)} s, so the constant piston "
        f"speed is {_g(speed)} ft/s.",
        "",
    ]

    out += ["### Design geometry", ""]
    out += [
        "d solves d^2 + 1.25 d - 1.21875 = 0 (design conditions); "
        "h = sqrt(d^2 + 1.25^2); theta_1 = arctan(1.25 / d).",
        "",
    ]
    rows = [
        ["d (ft)", _f(d, 10), _f(SAYS_GEAR["d"], 5)],
        ["other root of the quadratic (ft)", _f(roots[0], 10), _f(SAYS_GEAR["d_2"], 5)],
        ["h (ft)", _f(h, 10), _f(SAYS_GEAR["h"], 4)],
        ["theta_1 (rad)", _f(theta_1, 10), _f(SAYS_GEAR["theta_1"], 4)],
        ["theta_1 (deg)", _f(np.degrees(theta_1), 8), _f(SAYS_GEAR["theta_1_deg"], 2)],
        ["theta_end = theta_1 + pi/2 (deg)", _f(np.degrees(theta_1 + np.pi / 2), 8), ""],
    ]
    out += [_table(["quantity", "computed", "coursework says"], rows), ""]
    theta_end = lg.gear_from_piston(EXTENDED_FT, 0.0, 0.0, d, h)[0]
    out += [
        f"Check: at x = {_g(EXTENDED_FT)} ft the law of cosines gives theta = "
        f"{_f(float(np.degrees(theta_end)), 10)} deg, "
        f"{_below(abs(float(theta_end) - theta_1 - np.pi / 2), 1e-12, 'rad')} "
        f"of theta_1 + pi/2.",
        "",
    ]

    out += ["### Motion under the constant piston speed drive", ""]
    t = np.arange(int(round(T / TABLE_STEP)) + 1) * TABLE_STEP
    cs = _constant_speed(t, d, h)
    rows = [
        [_f(ti, 2), _f(np.degrees(th), 4), _f(x, 5), _f(om, 5), _f(al, 5)]
        for ti, th, x, om, al in zip(
            t,
            cs["gear_angle"],
            cs["piston_extension"],
            cs["gear_angular_velocity"],
            cs["gear_angular_acceleration"],
        )
    ]
    out += [
        _table(["t (s)", "theta (deg)", "x (ft)", "omega (rad/s)", "alpha (rad/s^2)"], rows),
        "",
    ]
    t_dead = (h + d - RETRACTED_FT) / speed
    out += [
        f"The assembly range is [|h - d|, h + d] = [{_f(abs(h - d), 5)}, {_f(h + d, 5)}] ft. "
        f"Run past T, the same drive reaches the dead centre x = h + d (sin theta = 0, "
        f"omega infinite) at t = {_f(t_dead, 4)} s.",
        "",
    ]

    # The two motion laws of the coursework.
    tf = np.linspace(0.0, T, FINE_SAMPLES)
    cs = _constant_speed(tf, d, h)
    theta_lin = theta_1 + np.pi * tf / 6.0
    dtheta, t_dtheta = _argmax_abs(cs["gear_angle"] - theta_lin, tf)
    out += ["### The coursework's two motion laws", ""]
    out += [
        "The coursework states both theta = theta_1 + pi t / 6 (linear in time) and a "
        f"constant piston speed of {_g(speed)} ft/s. They agree at t = 0 and t = T only. "
        f"On a grid of {FINE_SAMPLES} times over [0, {_g(T)}] s:",
        "",
    ]
    rows = [
        [
            "max abs(theta_constant_speed - theta_linear)",
            f"{_f(abs(np.degrees(dtheta)), 4)} deg",
            _f(t_dtheta, 3),
        ],
        ["sign there (constant speed minus linear)", "negative" if dtheta < 0 else "positive", ""],
    ]
    out += [_table(["quantity", "value", "at t (s)"], rows), ""]

    # What the script evaluates.
    _, omega_script, alpha_script = _law_omega_alpha(theta_lin, speed, d, h)
    x_lin = np.sqrt(h * h + d * d - 2.0 * d * h * np.cos(theta_lin))
    sin_lin, cos_lin = np.sin(theta_lin), np.cos(theta_lin)
    # Listing 1, line 20 writes anum2 = cos(theta) .* v, dropping eq. (6)'s factor f = x^2.
    alpha_printed = (d * h * sin_lin**2 * omega_script - cos_lin * omega_script) / (
        4.0 * d * h * sin_lin**2 * x_lin
    )
    omega_cs, alpha_cs = cs["gear_angular_velocity"], cs["gear_angular_acceleration"]
    omega_lin = np.pi / 6.0
    out += ["### What the coursework's script evaluates", ""]
    out += [
        "Its omega and alpha formulas (eqs. 5 and 6) are right for the constant piston "
        "speed law, but the script evaluates them at theta = theta_1 + pi t / 6, the "
        "linear law, whose own rates are omega = pi/6 rad/s and alpha = 0. The result "
        "belongs to neither law. Listing 1 line 20 also drops the factor f of eq. (6) "
        "(anum2 = cos(theta) .* v). Exact d and h are used below, to isolate these errors "
        "from the rounding.",
        "",
    ]
    rows = []
    for label, values, reference in [
        ("omega: script vs constant speed law", omega_script, omega_cs),
        ("omega: script vs linear law (pi/6)", omega_script, omega_lin),
        ("alpha (eq. 6): script vs constant speed law", alpha_script, alpha_cs),
        ("alpha (eq. 6): script vs linear law (0)", alpha_script, 0.0),
        ("alpha as printed (line 20): vs constant speed law", alpha_printed, alpha_cs),
    ]:
        error, at = _argmax_abs(values - reference, tf)
        rows.append([label, _f(error, 5), _f(at, 3)])
    out += [
        _table(["comparison", "max deviation (rad/s or rad/s^2, signed)", "at t (s)"], rows),
        "",
    ]
    out += [
        f"For scale: under constant piston speed omega runs from "
        f"{_f(omega_cs[0], 5)} to {_f(omega_cs[-1], 5)} rad/s and alpha from "
        f"{_f(alpha_cs[0], 5)} to {_f(alpha_cs[-1], 5)} rad/s^2.",
        "",
    ]

    # arcsin and rounding.
    out += ["### Errors in the constants", ""]
    out += [
        f"Coursework says: theta_1 = arcsin(1.25 / {SAYS_GEAR['d']}) = "
        f"{_f(SAYS_GEAR['theta_1_deg'], 2)} deg. The argument is 1.25 / d = "
        f"{_f(RETRACTED_FT / d, 6)} > 1: arcsin is undefined there. The intended value "
        f"is arctan(1.25 / d) = arcsin(1.25 / h) = "
        f"{_f(float(np.arcsin(RETRACTED_FT / h)), 6)} rad.",
        "",
    ]
    d_r, h_r = SAYS_GEAR["d"], SAYS_GEAR["h"]
    said_h = _f(h_r, 4)
    rows = [
        ["h (ft)", "", _f(h, 8), _f(h_r, 8), _f(SAYS_GEAR["h"], 4)],
        [
            "h^2 + d^2",
            "eq. 4",
            _f(h * h + d * d, 6),
            _f(h_r * h_r + d_r * d_r, 6),
            _f(SAYS_GEAR["h2+d2"], 4),
        ],
        ["2 d h", "eq. 4", _f(2 * d * h, 6), _f(2 * d_r * h_r, 6), _f(SAYS_GEAR["2dh"], 4)],
        ["4 d h", "eqs. 5, 6", _f(4 * d * h, 6), _f(4 * d_r * h_r, 6), _f(SAYS_GEAR["4dh"], 4)],
        ["d h", "eq. 6", _f(d * h, 6), _f(d_r * h_r, 6), _f(SAYS_GEAR["dh"], 4)],
    ]
    out += [
        _table(
            ["constant", "used in", "exact d, h", f"d = {d_r}, h = {said_h}", "coursework says"],
            rows,
        ),
        "",
    ]
    out += [
        f"Rounded to 4 decimals, h^2 + d^2 is {_f(h * h + d * d, 4)} with the exact h "
        f"but {_f(h_r * h_r + d_r * d_r, 4)} with h = {said_h}; 4 d h is "
        f"{_f(4 * d * h, 4)} with the exact h but {_f(4 * d_r * h_r, 4)} with h = {said_h}. "
        "The coursework's 2.3911 therefore comes from the rounded h and its 3.6196 from "
        "the exact one.",
        "",
    ]
    c = SAYS_GEAR
    theta_script = c["theta_1"] + np.pi * np.array([0.0, T]) / 6.0
    x_script = np.sqrt(c["h2+d2"] - c["2dh"] * np.cos(theta_script))
    out += [
        f"With the script's constants (coursework says theta_1 = {c['theta_1']}, "
        f"{c['h2+d2']}, {c['2dh']}) its piston length runs from {_f(x_script[0], 6)} ft "
        f"to {_f(x_script[1], 6)} ft instead of {_g(RETRACTED_FT)} to {_g(EXTENDED_FT)} ft.",
        "",
    ]
    return out


def _suspension_section():
    W = MASS * G
    h = float(sp.rest_height(L, D))
    u_star, F_star = sp.limit_point(L, K, D)
    roots = sp.equilibria(W, L, K, D)
    out = ["## 2. Car suspension (seed 003)", ""]
    out += [
        f"Inputs: L = {_g(L)} m, k = {_g(K)} N/m, d = {_g(D)} m, m = {_g(MASS)} kg, "
        f"g = {_g(G)} m/s^2, so W = m g = {_g(W, 8)} N.",
        "",
    ]
    out += [
        f"Rest height h = sqrt(L^2 - d^2) = {_f(h, 12)} m (coursework says "
        f"{SAYS_SUSPENSION['h'] * 100:.2f} cm).",
        "",
    ]

    out += ["### All equilibria for the coursework load", ""]
    out += [
        "F(u) = 2 k (L - s)(h - u) / s with s = sqrt(d^2 + (h - u)^2). The roots come "
        "from the quartic in v = h - u, each checked against the unsquared equation and "
        f"polished by Newton. On u >= 0 there are {int(np.sum(roots >= 0.0))}:",
        "",
    ]
    rows = []
    says_u, says_k = SAYS_SUSPENSION["u"], SAYS_SUSPENSION["kef"]
    for i, u in enumerate(roots[roots >= 0.0]):
        secant = float(sp.secant_stiffness(u, L, K, D))
        tangent = float(sp.tangent_stiffness(u, L, K, D))
        force = float(sp.spring_force(u, L, K, D))
        stable, marginal = (bool(x) for x in sp.stability(tangent, K))
        frequency = _f(np.sqrt(tangent / MASS) / (2 * np.pi), 4) if stable else "-"
        says = f"u = {says_u[i]}, Kef = {says_k[i]:.4e}" if i < len(says_u) else "(missed)"
        rows.append(
            [
                f"u{i + 1}",
                _f(u, 10),
                _f(force, 6),
                _f(secant, 2),
                _f(tangent, 2),
                "stable" if stable else "marginal" if marginal else "unstable",
                frequency,
                says,
            ]
        )
    out += [
        _table(
            [
                "",
                "u (m)",
                "F(u) (N)",
                "secant F/u (N/m)",
                "tangent dF/du (N/m)",
                "stability",
                "f_n (Hz)",
                "coursework says",
            ],
            rows,
        ),
        "",
    ]
    out += [
        f"The coursework's secant stiffness Kef = F/u is positive at all three; only the "
        f"tangent stiffness tells that u2 is unstable. u3 lies beyond 2h = {_f(2 * h, 6)} m "
        f"(springs pushed through and below their lower ends), outside the coursework's "
        f"search interval [0, 0.5] m. f_n = sqrt(tangent / m) / (2 pi) for the "
        f"{_g(MASS)} kg mass.",
        "",
    ]

    out += ["### Limit load and snap-through", ""]
    rows = [
        ["near branch ends (u*, F*)", _f(u_star, 10), _f(F_star, 6)],
        ["far branch ends (mirror 2h - u*, -F*)", _f(2 * h - u_star, 10), _f(-F_star, 6)],
    ]
    out += ["dF/du = 2 k (1 - L d^2 / s^3) vanishes at s*^3 = L d^2.", ""]
    out += [_table(["point", "u (m)", "F (N)"], rows), ""]
    out += [
        f"The tangent stiffness at u* is zero to rounding "
        f"({_below(abs(float(sp.tangent_stiffness(u_star, L, K, D))), 1e-9, 'N/m')}). "
        f"A load above F* = {_f(F_star, 3)} N, i.e. a mass above F*/g = "
        f"{_f(F_star / G, 3)} kg, has no near equilibrium: the suspension snaps through "
        f"to the far branch. The coursework load is {_f(100 * W / F_star, 2)} % of F*.",
        "",
    ]

    out += ["### Secant stiffness at u -> 0", ""]
    limit = 2 * K * h * h / (L * L)
    out += [
        f"F(u)/u is 0/0 at u = 0. Writing L - s = u (2h - u) / (L + s) gives "
        f"F/u = 2 k (2h - u)(h - u) / (s (L + s)), whose limit is 2 k h^2 / L^2 = "
        f"{_f(limit, 6)} N/m (the exact form evaluated at u = 0: "
        f"{_f(float(sp.secant_stiffness(0.0, L, K, D)), 6)} N/m). The coursework's form "
        "(naive, with h = sqrt(L^2 - d^2)) loses digits as u shrinks:",
        "",
    ]
    h_naive = np.sqrt(L**2 - D**2)
    rows = []
    for exponent in NAIVE_EXPONENTS:
        u = 10.0**-exponent
        s = np.sqrt(D**2 + (h_naive - u) ** 2)
        naive = 2 * K * (L - s) * (h_naive - u) / s / u
        exact = float(sp.secant_stiffness(u, L, K, D))
        error = abs(naive / exact - 1.0)
        rows.append([f"1e-{exponent}", _f(naive, 6), _f(exact, 6), _g(error, 2)])
    out += [_table(["u (m)", "naive F/u (N/m)", "exact form (N/m)", "relative error"], rows), ""]

    out += ["### Spurious preload from rounding h", ""]
    h_r = SAYS_SUSPENSION["h"]
    s0 = np.sqrt(D**2 + h_r**2)
    preload = 2 * K * (L - s0) * h_r / s0
    shift = h_r - h
    u1 = float(roots[roots >= 0.0][0])
    out += [
        f"The coursework writes h = {h_r * 100:.2f} cm (coursework says; its MATLAB "
        f"scripts compute h exactly). With h rounded to {h_r} m the springs at "
        f"u = 0 have length {_f(s0, 9)} m instead of L = {_g(L)} m, so F(0) = "
        f"{_f(preload, 4)} N instead of 0: the springs are stretched by "
        f"{_g((s0 - L) * 1e6, 3)} um and pull the top down. F depends on u only through "
        f"h - u, so the rounded model is the exact one shifted by h_rounded - h = "
        f"{_g(shift * 1e6, 4)} um (check: exact F at u = -{_g(shift * 1e6, 4)} um is "
        f"{_f(float(sp.spring_force(-shift, L, K, D)), 4)} N). Every equilibrium it finds "
        f"is {_g(shift * 1e6, 4)} um too deep: u1 = {_f(u1 + shift, 7)} m instead of "
        f"{_f(u1, 7)} m.",
        "",
    ]
    return out


def _four_bar_section():
    """Seed 001: the worked four-bar example on both circuits, and its Grashof condition."""
    ground, crank, coupler, rocker = COURSEWORK_FOUR_BAR
    inches = [length / INCH for length in (crank, coupler, rocker, ground)]
    shortest, longest = min(inches), max(inches)
    others = sum(inches) - shortest - longest
    out = ["## 3. Four-bar linkage (seed 001)", ""]
    out += [
        f"a, b, c, d = {', '.join(_g(v) for v in inches)} in (crank, coupler, rocker, "
        f"ground), theta2 = {_g(np.degrees(COURSEWORK_CRANK_ANGLE))} deg, crank speed "
        f"1 rad/s, no crank acceleration. Grashof: S + L = {_g(shortest + longest)} in "
        f"{'<' if shortest + longest < others else '>='} P + Q = {_g(others)} in, the "
        f"shortest link is the crank: a crank-rocker. Angles from the numpy reference "
        f"(circle intersection, independent of the FMU's Freudenstein form).",
        "",
    ]
    rows = []
    for circuit, name in ((0, "open"), (1, "crossed")):
        m = linkages.four_bar(
            ground, crank, coupler, rocker, circuit, COURSEWORK_CRANK_ANGLE, 1.0, 0.0
        )
        rows.append(
            [
                name,
                _f(np.degrees(m["coupler_angle"]), 4),
                _f(np.degrees(m["rocker_angle"]), 4),
                _f(np.degrees(m["transmission_angle"]), 4),
                _f(m["coupler_angular_velocity"], 5),
                _f(m["rocker_angular_velocity"], 5),
                _f(m["coupler_angular_acceleration"], 5),
                _f(m["rocker_angular_acceleration"], 5),
            ]
        )
    out += [
        _table(
            [
                "circuit",
                "theta3 (deg)",
                "theta4 (deg)",
                "mu (deg)",
                "omega3 (rad/s)",
                "omega4 (rad/s)",
                "alpha3 (rad/s^2)",
                "alpha4 (rad/s^2)",
            ],
            rows,
        ),
        "",
    ]
    return out


def _cam_section():
    """Seed 002: cam-law peak coefficients (closed form vs dense numerical maxima) and the
    default valve train's lift ratio and float speeds."""
    out = ["## 4. Cam-driven valve train (seed 002)", ""]
    x = np.linspace(0.0, 1.0, 1_000_001)
    rows = []
    for law in cam_laws.CAM_LAWS:
        _, f1, f2 = vt.normalized(law, x)
        f3 = np.gradient(f2, x, edge_order=2)
        closed = cam_laws.peak_coefficients(law)
        smooth = cam_laws.CONTINUITY[law]
        numeric = (np.max(np.abs(f1)), np.max(np.abs(f2)), np.max(np.abs(f3)))
        rows.append(
            [law]
            + [f"{_f(c, 4)} ({_f(n, 4)})" for c, n in zip(closed, numeric)]
            + [
                "continuous" if smooth.acceleration else "jumps",
                "continuous" if smooth.jerk else "jumps",
            ]
        )
    out += [
        "Peak |velocity|, |acceleration| and |jerk| coefficients of the normalized rise "
        "(lift 1 over a rise angle 1): closed form, and in parentheses the maximum over "
        "10^6 + 1 points of the numpy reference (jerk by central differences of the "
        "acceleration). At the segment ends the acceleration or the jerk may jump, "
        "which the coefficients do not show:",
        "",
    ]
    out += [_table(["law", "C_v", "C_a", "C_j", "acceleration at ends", "jerk at ends"], rows), ""]
    g = DEFAULT_VALVE_GEOMETRY._asdict()
    motion = vt.forward(g, 0.007, 1.0, 0.0)
    rest = vt.forward(g, 0.0, 1.0, 0.0)
    out += [
        f"Valve train with the documented default geometry (rocker arms "
        f"{_g(g['tappet_arm'] * 1e3)} and {_g(g['valve_arm'] * 1e3)} mm): 7 mm of tappet "
        f"lift gives {_f(float(motion['valve_lift']) * 1e3, 4)} mm of valve lift; "
        f"d(valve lift)/d(tappet lift) = {_f(float(rest['valve_velocity']), 4)} at rest "
        f"and {_f(float(motion['valve_velocity']), 4)} at 7 mm.",
        "",
    ]
    defaults = model_defaults("ValveTrain")
    mass, stiffness, preload = (
        defaults[name] for name in ("valve_mass", "spring_stiffness", "spring_preload")
    )
    angle = np.linspace(0.0, 2.0 * np.pi, 200_001)
    rows = []
    for law in cam_laws.CAM_LAWS:
        s, s1, s2 = vt.cam_lift(law, 0.007, 0.0, 1.2, 0.1, 1.2, angle)
        valve = vt.forward(g, s, s1, s2)  # at 1 rad/s: acceleration = d2(lift)/dtheta2
        decelerating = valve["valve_acceleration"] < 0.0
        speed2 = np.where(
            decelerating,
            (stiffness * valve["valve_lift"] + preload)
            / (mass * -np.where(decelerating, valve["valve_acceleration"], -1.0)),
            np.inf,
        )
        i = int(np.argmin(speed2))
        w = float(np.sqrt(speed2[i]))
        rows.append([law, _f(w, 1), _f(w * 2.0 * 60.0 / (2.0 * np.pi), 0), _f(angle[i], 3)])
    out += [
        f"Valve float: with a {_g(mass)} kg valve, a {_g(stiffness / 1e3)} kN/m spring "
        f"and {_g(preload)} N preload, 7 mm cam lift, rise and return over 1.2 rad and a "
        f"0.1 rad dwell, the contact force m a + k L + F0 first reaches zero at constant "
        f"camshaft speed (minimum over 200 001 camshaft angles):",
        "",
    ]
    out += [
        _table(["law", "camshaft (rad/s)", "engine (rpm)", "at camshaft angle (rad)"], rows),
        "",
    ]
    return out


def _cam_geometry_section():
    """Seed 002's open aims: the cam's geometry from the follower motion (each law on the
    default valve train, flat tappet and 8 mm roller) and the torque the camshaft needs,
    one lobe and the inline four's camshaft in its firing order against wrong ones."""
    from mechfmu.api import reference
    from mechfmu.cosim.scene import find_file, load_scene
    from mechfmu.tools import camshaft

    out = ["### Cam geometry from the desired motion (seed 002's general objective)", ""]
    base, roller = DEFAULT_VALVE_GEOMETRY.cam_base_radius, 0.008
    rows, fine = [], []
    for law in cam_laws.CAM_LAWS:
        profile = cam_laws.check_profile(law, 0.007, 0.0, 1.2, 0.1, 1.2)
        pieces = cam_geometry.law_pieces(profile)
        flat = cam_geometry.design(cam_geometry.check_follower("flat_faced", base), pieces)
        rolling = cam_geometry.design(cam_geometry.check_follower("roller", base, roller), pieces)
        flat_size = cam_geometry.smallest_base_circle("flat_faced", pieces)
        roller_size = cam_geometry.smallest_base_circle("roller", pieces, roller)
        if not rolling.problems:
            fine.append(law)
        rows.append(
            [
                law,
                _f(flat.least_radius * 1e3, 3),
                _f(flat_size.base_circle_radius * 1e3, 3),
                _f(flat.face_width * 1e3, 3),
                _f(np.degrees(abs(rolling.largest_pressure_angle)), 2),
                _f(rolling.least_radius * 1e3, 3),
                f"{_f(roller_size.base_circle_radius * 1e3, 3)} ({roller_size.limit})",
            ]
        )
    out += [
        f"The cam under the tappet for 7 mm of lift, rise and return over 1.2 rad, a 0.1 rad "
        f"dwell (runtime/physics/cam_geometry.py). On the project's {_g(base * 1e3)} mm base "
        f"circle a flat tappet's cam has a cusp wherever the least radius of curvature "
        f"Rb + s + s'' is negative: each law needs the smallest base circle below. An "
        f"{_g(roller * 1e3)} mm roller on the same base circle makes a cam without undercut "
        f"or a pressure angle over 30 deg for {', '.join(fine) or 'none of them'}; its "
        f"smallest base circle is set by that pressure angle or by the undercut (pitch-curve "
        f"radius above the roller's), whichever needs more:",
        "",
    ]
    out += [
        _table(
            [
                "law",
                "flat: least rho at 15 mm (mm)",
                "flat: smallest Rb (mm)",
                "face swept (mm)",
                "roller: largest pressure angle (deg)",
                "roller: least rho (mm)",
                "roller: smallest Rb (mm)",
            ],
            rows,
        ),
        "",
    ]
    scene = load_scene(find_file("camshaft_inline_four"))
    lobe = load_scene(find_file("valve_train"))
    single = reference(lobe)
    torque = camshaft.fluctuation(single["valve.camshaft_torque"])
    valve, drive = (
        {**model_defaults(Path(spec.fmu).stem), **spec.parameters}
        for spec in (lobe.components["valve"], lobe.components["camshaft"])
    )
    law, mass, stiffness, preload = (
        valve[name] for name in ("cam_law", "valve_mass", "spring_stiffness", "spring_preload")
    )
    speed = CamshaftDrive.RATIO * drive["speed"]
    out += [
        "### The torque the camshaft needs",
        "",
        f"One lobe (the valve_train scene: {law} cam, {_g(mass)} kg valve, "
        f"{_g(stiffness / 1e3)} kN/m spring, {_g(preload)} N preload, camshaft at "
        f"{_f(speed, 1)} rad/s): the torque F dL/dtheta swings "
        f"{_f(torque['peak_to_peak'], 3)} N.m peak to peak (RMS {_f(torque['rms'], 3)} N.m); "
        f"over a revolution its mean is {torque['mean']:.1e} N.m: the spring and the valve's "
        f"inertia give back on the return what the rise took (computed from the rocker's "
        f"statics, references/cam_geometry.py).",
        "",
    ]

    def run(chosen: Any, parameters: Any) -> Any:
        return reference(chosen, parameters=parameters)

    table, _ = camshaft.compare_phasings(scene, run)
    rows = [
        [
            name,
            _f(row["peak_to_peak"], 3),
            _f(row["rms"], 3),
            _f(row["largest_section_torque"], 3),
        ]
        for name, row in table.iterrows()
    ]
    out += [
        "The inline four's camshaft (camshaft_inline_four: eight such lobes, intake lobes a "
        "quarter turn apart in the firing order, exhaust lobes 110 deg ahead of them). The "
        "coursework says the cams must act in the correct sequence so that the torque the "
        "engine supplies fluctuates as little as possible. The total torque is a sum of one "
        "lobe's torque over the lobes' phases, so it depends only on the set of phases: any "
        "firing order of evenly spaced lobes gives the same total (the first two rows agree "
        "to rounding). What keeps the fluctuation low is the even spacing itself; lobes "
        "mounted at the crank throws' angles (forgetting that the camshaft turns at half "
        "speed) double the swing. The firing order matters for the crankshaft's balance, "
        "not for the camshaft's total torque:",
        "",
        _table(
            ["phasing", "peak-to-peak (N.m)", "RMS (N.m)", "largest in a shaft section (N.m)"],
            rows,
        ),
        "",
    ]
    return out


def build_report() -> Any:
    """The seed-reproduction report as Markdown text."""
    lines = ["# Seed reproduction: landing gear, suspension, four-bar and valve train", ""]
    lines += [
        "Generated by `sims/seed_report.py` from the numpy references in "
        "`mechfmu.references`. Every number is computed; values labelled "
        '"coursework says" are quoted from the coursework for comparison.',
        "",
    ]
    lines += _landing_gear_section()
    lines += _suspension_section()
    lines += _four_bar_section()
    lines += _cam_section()
    lines += _cam_geometry_section()
    return "\n".join(lines).rstrip("\n") + "\n"


def write_report(path: Any) -> Any:
    """Write ``build_report()`` to ``path`` (parent directories created); return the Path."""
    return atomic_write(path, build_report())
