"""The resonance peak of one measured FRF curve: frequency and height of the maximum of |H|.

A noisy curve's largest line lies above its peak: with relative noise σ on each line, the
maximum over the n lines within σ of the top is about σ·√(2 ln n) high (2 % complex noise,
~1.4 % on |H|, ten lines near the top: +2 %), and a parabola through it and its two
neighbours inherits that. A stepped-sine sample's damping ratio is inversely proportional to
the peak's height, so it came out 1–3 % low on every level of a simulated Jenkins SDOF
(benchmarks/test_type_truth.py, 8 seeds), and its amplitude as much too high.

Single-nonlinear-mode theory (docs/iwan.md §4, the damping hysteretic:
:mod:`nlupdate.core.model.single_mode`) gives the curve near the top: at amplitude A on a
curve of force F, ``(ω² − Ω²)² + (2ζω²)² = (φ²F/(A·φ))²`` with ω, ζ at A, i.e. in ``u = Ω²``
and ``y = 1/|H|²`` (∝ 1/A²)::

    (u − c(y))² = K·y − 4ζ²ω⁴,      c = ω²  (the backbone at A).

The right side vanishes at the peak ``(c₀, y₀)``; near it, with c and the right side taken
linear in ``y − y₀``, the curve is a parabola with a tilted axis,
``(u − c₀ − c₁(y − y₀))² = K(y − y₀)``: exact for a linear mode (c₁ = 0: ``1/|H|²`` is a
quadratic in Ω²), and the tilt c₁ is the backbone's slope, which skews a softening or
stiffening curve. :func:`resonance_peak` fits it by least squares in the relative error of
``1/|H|²`` (the noise of |H| is a share of it) over the lines with |H| at least
:data:`TOP_SHARE` of the largest line's, started from the untilted quadratic, and returns its
vertex. Measured on the Jenkins systems of benchmarks/test_type_truth.py (six levels from
stuck to 15 × the slip amplitude, 301 lines, 2 % noise, 8 seeds): every level within 8.8e-4 in
frequency and 1.5 % in damping, against 5.2e-3 and 24 % for the parabola through the largest
line and its neighbours, which was 1–5 % low in damping on average at every level; without
the tilt (a quadratic in Ω²) the frequency of the level that peaks at 1.9 × the slip amplitude,
where the backbone falls steeply, was 1.1–2.4e-3 high on average. Where the fit has fewer than
:data:`MIN_LINES` lines, fails, or puts its vertex outside them, that parabola is taken.

A fit that has not converged after :data:`MAX_EVALUATIONS` evaluations of its residual fails
(scipy's ``max_nfev``, whose default, 100 per coefficient, was 400; like ``nfev`` it leaves out
the four more evaluations of each finite-difference Jacobian, so a fit calls the residual up
to five times as often). A top the tilted parabola cannot hold — the
Brake–Reuss beam's 0.4886 N level, whose six lines above 0.8 of its largest zig-zag
(0.93, 1, 0.87, 0.91, 0.88, 0.82) — sends it down a valley towards K → 0 (a kink, not a
parabola) that it follows for all 400 evaluations before failing: 63 such fits were half the
CPU time of ``nlupdate amplitude --band 80:80.6`` on that beam (the noisy copies of its band
check). Measured on 1233 fits (that command with ``--band`` 80:80.6, 80.1:80.5, 79.2:80.2,
79.7:80.9 and 80.0:81.2 and without it; tests/test_frf_peak.py, test_stepped_sine_truth.py and
test_achieved_force_modal_model.py): every fit whose vertex was taken converged within 36
evaluations, and every fit that took more than 50 ended outside its lines or unconverged, i.e.
in this parabola, which the cap gives the same (that command's stdout, stderr and files
byte-identical with these bands, 79.5:81.0 and none; 2026-11-30).
"""
from __future__ import annotations

import numpy as np
import scipy.optimize
from numpy.typing import NDArray

#: lines whose |H| is at least this share of the largest line's are fitted (a linear mode:
#: the middle 75 % of its half-power band)
TOP_SHARE = 0.8
#: fewest lines the tilted parabola is fitted to (it has four coefficients)
MIN_LINES = 6
#: residual evaluations (scipy's ``max_nfev``: Jacobian evaluations not counted) after which the
#: tilted parabola's fit fails (module docstring: every fit whose vertex was taken needed at most 36)
MAX_EVALUATIONS = 100


def _three_point(f: NDArray, magnitude: NDArray, i: int) -> tuple[float, float]:
    """Parabola through line i and its neighbours: (frequency, height) of its vertex."""
    i = int(np.clip(i, 1, f.size - 2))
    y0, y1, y2 = magnitude[i - 1 : i + 2]
    curvature = y0 - 2 * y1 + y2
    shift = float(np.clip(0.5 * (y0 - y2) / curvature, -1, 1)) if curvature < 0 else 0.0
    return float(f[i] + shift * 0.5 * (f[i + 1] - f[i - 1])), float(y1 - 0.25 * (y0 - y2) * shift)


def _tilted(theta: NDArray, u: NDArray) -> NDArray:
    """y on the tilted parabola ``(u − c₀ − c₁(y − y₀))² = K(y − y₀)``, θ = (c₀, c₁, ln K, y₀):
    its lower branch, ``y − y₀ = 2d²/(b + √(b² − 4c₁²d²))``, d = u − c₀, b = K + 2c₁d (the
    form that stays finite as c₁ → 0; past the curve's fold, where b² < 4c₁²d², its edge)."""
    c0, c1, log_k, y0 = theta
    d = u - c0
    b = np.exp(log_k) + 2 * c1 * d
    return y0 + 2 * d**2 / (b + np.sqrt(np.maximum(b**2 - 4 * c1**2 * d**2, 0.0)))


def resonance_peak(frequency_hz: NDArray, magnitude: NDArray) -> tuple[float, float]:
    """(frequency Hz, |H|) of the peak of one curve sampled at increasing ``frequency_hz``
    with magnitudes ``magnitude`` (≥ 3 lines; module docstring)."""
    f, m = np.asarray(frequency_hz, float), np.asarray(magnitude, float)
    top = int(np.argmax(m))
    low = top
    while low > 0 and m[low - 1] >= TOP_SHARE * m[top]:
        low -= 1
    high = top
    while high < m.size - 1 and m[high + 1] >= TOP_SHARE * m[top]:
        high += 1
    if high - low + 1 < MIN_LINES:
        return _three_point(f, m, top)
    u = (f[low : high + 1] / f[top]) ** 2 - 1  # Ω²/Ω_top² − 1
    y = (m[top] / m[low : high + 1]) ** 2  # 1/|H|², 1 at the largest line
    design = np.stack([np.ones_like(u), u, u**2], axis=1) / y[:, None]  # untilted: a quadratic in u
    a0, a1, a2 = np.linalg.lstsq(design, np.ones_like(u), rcond=None)[0]
    if a2 <= 0:
        return _three_point(f, m, top)
    start = np.array([-a1 / (2 * a2), 0.0, -np.log(a2), a0 - a1**2 / (4 * a2)])
    with np.errstate(all="ignore"):
        fit = scipy.optimize.least_squares(lambda t: _tilted(t, u) / y - 1, start, x_scale="jac",
                                            max_nfev=MAX_EVALUATIONS)
    c0, _, _, y0 = fit.x
    if not (fit.success and u[0] <= c0 <= u[-1] and y0 > 0):
        return _three_point(f, m, top)
    return float(f[top] * np.sqrt(1 + c0)), float(m[top] / np.sqrt(y0))
