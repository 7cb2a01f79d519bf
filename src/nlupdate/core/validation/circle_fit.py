"""Damping ratio of one receptance curve by a modal circle fit (Kennedy–Pancu) around its peak.

An SDOF receptance ``H = A/(ω_r² − Ω² + 2iζω_rΩ)`` (complex modal constant A) has a mobility
``iΩH`` that is exactly a circle in the complex plane, and the angle ψ of a point about the
circle's centre obeys ``ψ − ψ_r = ±2 atan((ω_r² − Ω²)/(2ζω_rΩ))``. The fit:

1. the lines: the contiguous run of lines around the largest |H| with |H| ≥
   :data:`CIRCLE_FRACTION` × max|H| (for an SDOF about 2.3 half-power bandwidths wide);
2. a circle through their mobility points, algebraically (least squares of
   ``|y|² = a·Re y + b·Im y + c``);
3. ω_r, ζ and ψ_r by least squares of the angle law, both senses of rotation tried, the
   smaller misfit kept.

Only ζ is returned; the resonance frequency and peak of a comparison come from the peak
(:mod:`nlupdate.core.validation.resonance`). Other modes add a near-constant to the mobility
over so narrow a band, which moves the circle, not the angles about its centre.

The damping ratio is NaN (the curve does not trace the resonance's circle) when

* fewer than :data:`MIN_CIRCLE_LINES` lines lie in the run (a half-power band of less than
  about two lines, or a band too narrow), or
* the largest |H| is the run's first or last line: on one side |H| falls below the fraction
  in one step or the band ends — a jump (a fold of a nonlinear force-controlled sweep) or a
  resonance at the band's edge;
* the curve is a magnitude (real), which has no circle.

**A jump inside the run** (a fold of a stepped-sine sweep that lands above the fraction) is
found by :func:`jump_in_run`, and the caller (:mod:`nlupdate.core.validation.resonance`)
then reads the half-power value instead. The rule, both parts needed:

* *beyond a linear mode:* a single linear mode of damping ratio ζ at ω_r has
  ``|H| ∝ 1/√(1 + x²)``, ``x = (ω_r² − Ω²)/(2ζω_rΩ)``, so between two lines whose x differ by
  δ its |H| changes by at most the factor ``δ/2 + √(1 + δ²/4)`` (the two lines astride a
  half-power point). The step ``|ln(|H_{i+1}|/|H_i|)|`` exceeds that bound for
  :data:`JUMP_ZETA_FACTOR` × δ (ζ the curve's half-power value, allowed to be 2× high) by
  more than :data:`JUMP_NOISE_SIGMAS` × the curve's relative noise σ
  (:func:`nlupdate.core.measurement.noise.estimate_noise_fraction`; ln of a one-line ratio
  carries noise of std ≈ σ; on linear curves with 0–2 % noise the excess stayed below 5.3 σ);
* *a discontinuity:* the step is more than :data:`JUMP_STANDS_OUT` × both neighbouring
  steps of ln|H|. Without it the bent but continuous flank of a strongly nonlinear curve is
  called a jump: the transmitter beam's four measured curves (docs/validation.md) and many of
  the BRB models' predicted curves are steeper on one flank than any linear mode of their
  half-power width, yet step smoothly from line to line.

No noise estimate (fewer than 9 contiguous lines): no jump is called. Cutting the run at
the jump instead does not work: on a hardening sweep up the peak *is* the fold, so the side
holding the peak ends at its peak (the rule above: NaN); on the closed-form Duffing jump
(tests/test_circle_fit.py) the half-power value is within 5 %.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import least_squares

from nlupdate.core.measurement.noise import estimate_noise_fraction

#: The lines fitted: |H| at least this fraction of the largest |H|, contiguous around it.
CIRCLE_FRACTION = 0.4
#: Fewer lines than this in the run: the damping ratio is NaN.
MIN_CIRCLE_LINES = 5
#: The linear bound of a step is that of a mode this many times less damped than the curve.
JUMP_ZETA_FACTOR = 2.0
#: A step of ln|H| beyond the linear bound by more than this many noise stds ...
JUMP_NOISE_SIGMAS = 8.0
#: ... and this many times both neighbouring steps of ln|H| is a jump.
JUMP_STANDS_OUT = 1.5


def circle_window(h: ArrayLike, fraction: float = CIRCLE_FRACTION) -> slice:
    """The contiguous lines around the largest |h| with |h| ≥ ``fraction`` × max|h|."""
    m = np.abs(np.asarray(h))
    k = int(np.argmax(m))
    low, high = k, k
    while low > 0 and m[low - 1] >= fraction * m[k]:
        low -= 1
    while high < m.size - 1 and m[high + 1] >= fraction * m[k]:
        high += 1
    return slice(low, high + 1)


def jump_steps(frequency_hz: ArrayLike, h: ArrayLike, zeta: float) -> np.ndarray:
    """The steps that make a jump by the module's rule: indices i (line i to line i + 1) inside
    the run (:func:`circle_window`) of ``h`` (complex or magnitude, over ``frequency_hz`` in
    Hz, increasing) whose step of ln|h| lies beyond what a linear mode of damping ratio
    ``zeta`` (fraction of critical) allows and stands out from both neighbouring steps. Empty
    for a non-positive or NaN ``zeta`` or a curve too short to estimate its noise."""
    f = np.asarray(frequency_hz, dtype=float)
    h = np.asarray(h)
    if not (np.isfinite(zeta) and zeta > 0):
        return np.zeros(0, dtype=int)
    try:
        sigma = estimate_noise_fraction(f, h.astype(complex))
    except ValueError:
        return np.zeros(0, dtype=int)
    m = np.abs(h)
    w = 2 * np.pi * f
    wr = w[int(np.argmax(m))]
    delta = JUMP_ZETA_FACTOR * np.abs(np.diff((wr**2 - w**2) / (2 * zeta * wr * w)))
    step = np.abs(np.diff(np.log(m)))
    beyond = step > np.log(delta / 2 + np.sqrt(1 + delta**2 / 4)) + JUMP_NOISE_SIGMAS * sigma
    neighbour = np.maximum(np.r_[0.0, step[:-1]], np.r_[step[1:], 0.0])
    window = circle_window(h)
    inside = np.arange(window.start, window.stop - 1)
    return inside[beyond[inside] & (step[inside] > JUMP_STANDS_OUT * neighbour[inside])]


def jump_in_run(frequency_hz: ArrayLike, h: ArrayLike, zeta: float) -> bool:
    """Whether two adjacent lines of the run (:func:`circle_window`) of ``h`` make a jump by
    the module's rule (:func:`jump_steps`)."""
    return bool(jump_steps(frequency_hz, h, zeta).size)


def angle_misfit(p: np.ndarray, w: np.ndarray, psi: np.ndarray, sign: float) -> np.ndarray:
    """The circle fit's angle residual (rad) at the lines ``w`` (rad/s) for ``p`` = (ω_r rad/s,
    ζ, the angle's offset rad): ``2 arctan((ω_r² − ω²)/(2ζω_rω)) − sign·(ψ − offset)``, ψ the
    points' unwrapped angles about the circle's centre (:func:`circle_fit_damping`)."""
    return 2 * np.arctan((p[0] ** 2 - w**2) / (2 * p[1] * p[0] * w)) - sign * (psi - p[2])


def angle_misfit_jacobian(p: np.ndarray, w: np.ndarray, psi: np.ndarray, sign: float) -> np.ndarray:
    """∂(:func:`angle_misfit`)/∂p in closed form, one row per line: with
    u = (ω_r² − ω²)/(2ζω_rω), ∂u/∂ω_r = 1/(2ζω) + ω/(2ζω_r²) and ∂u/∂ζ = −u/ζ."""
    u = (p[0] ** 2 - w**2) / (2 * p[1] * p[0] * w)
    slope = 2 / (1 + u**2)
    return np.column_stack([slope * (1 / (2 * p[1] * w) + w / (2 * p[1] * p[0] ** 2)), -slope * u / p[1],
                            np.full(w.shape, float(sign))])


def circle_fit_damping(frequency_hz: ArrayLike, h: ArrayLike, start_zeta: float = float("nan")) -> float:
    """Damping ratio (fraction of critical) of the receptance ``h`` (complex, any unit per
    force) over ``frequency_hz`` (Hz, strictly increasing, finite lines only) by the modal
    circle fit of the module's docstring; ``start_zeta`` seeds the angle fit (NaN: from the
    run's width). NaN under the module's rules."""
    f = np.asarray(frequency_hz, dtype=float)
    h = np.asarray(h)
    if not np.iscomplexobj(h) or f.size < MIN_CIRCLE_LINES:
        return float("nan")
    window = circle_window(h)
    k = int(np.argmax(np.abs(h))) - window.start
    count = window.stop - window.start
    if count < MIN_CIRCLE_LINES or k == 0 or k == count - 1:
        return float("nan")
    w = 2 * np.pi * f[window]
    y = 1j * w * h[window]
    c = np.linalg.lstsq(np.column_stack([y.real, y.imag, np.ones(w.size)]), np.abs(y) ** 2, rcond=None)[0]
    psi = np.unwrap(np.angle(y - (c[0] + 1j * c[1]) / 2))
    wn = float(w[k])
    if not (np.isfinite(start_zeta) and 0 < start_zeta < 0.5):
        # the run spans about ±2.29 ζ ω_r for an SDOF (|H| = 0.4 max|H|)
        start_zeta = float(np.clip((w[-1] - w[0]) / (4 * 2.29 * wn), 1e-5, 0.4))
    best = None
    for sign in (1.0, -1.0):
        fit = least_squares(angle_misfit, [wn, start_zeta, psi[k]], jac=angle_misfit_jacobian, args=(w, psi, sign),
                            x_scale=[wn * 1e-3, start_zeta, 1.0], xtol=1e-12,
                            bounds=([0, 1e-6, -np.inf], [np.inf, 0.5, np.inf]))
        best = fit if best is None or fit.cost < best.cost else best
    return float(best.x[1])
