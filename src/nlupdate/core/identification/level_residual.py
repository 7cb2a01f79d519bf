"""The other modes' share of a mode's stepped-sine FRFs, and its modal constant, from every
force level at once (single-nonlinear-mode theory).

A force-controlled stepped-sine curve near a well-separated resonance is the mode plus the
other modes' share: ``H = P/(ω(a)² − Ω² + 2iζ(a)ω(a)²) + share`` (P = φ_rφ_f, the modal
constant; the damping hysteretic, :mod:`nlupdate.core.model.single_mode`). The other modes
are far and linear, so their share is the same at every level; the mode is not linear, and a linear
one-mode fit of one level — the lowest, as the peak samples took it before — takes part of
that curve's amplitude dependence for residual terms and modal constant. On a closed-form
single mode (no other mode at all) whose damping grows 1.5 × across three levels
(tests/test_achieved_force_modal_model.py) that fit put R at 2.9 % of the lowest peak, and
the peak samples read 2.8–4.9 % high in amplitude and 3.8–7.5 % low in damping; with R
constant (no residual mass) 2.8–4.7 % and 3.7–7.3 %; a linear fit of every level with one
shared R was worse still (4.0–6.9 %, 5.2–10.3 %: every level's curve is nonlinear).

What single-mode theory says instead: with the right share and P every line is a sample of
the mode's two curves, ``D = P/(H − share)``, ``ω(a)² = Re D + Ω²``, ``2ζ(a)ω(a)² = Im D`` at
``a ∝ |H − share|·F`` (F the force achieved at that line; the damping hysteretic,
:func:`~nlupdate.core.model.single_mode.natural_and_damping`), and a level's two flanks pass
through the same amplitudes, so they must give the same ω(a) and ζ(a). A wrong P splits
them (``ω²`` reads ``cω² + (1 − c)Ω²`` for P off by c), a wrong share bends them apart, and
by as much at every level. :func:`level_residual` takes the share ``R + S·(f²/f_c² − 1)``
(complex R and S: the modes above and below, far and linear; S is the share's slope, as a
mode 25 % away gives over ±1 %) and the P that make every line of every level in the band
lie on that level's own polynomials of :data:`ORDER` in a/a_max — ``Re D + Ω²`` and
``Im D``, each misfit over |D|, so in units of H's relative noise: the lines far from
resonance, where the share is the larger part of H, count as their noise allows. The curves
are each level's own because one curve through all levels cannot follow a backbone over
decades of amplitude (on the 2-DOF Iwan system of tests/test_amplitude_limits.py, stuck to
macroslip, one quadratic through the lines near every top put R at 20 % of the lowest peak
and P at 2.4 × the truth). Tried and not kept: R alone (no S) from the lines near each
level's top (|H| ≥ half its peak), unweighted — on the harmonic-balance Jenkins 2-DOF of
tests/test_stepped_sine_truth.py with 2 % noise one seed read a level's damping 6.2 % off (the
share from a few noisy lines); with S, every line, weighted: 1.8 % (the lowest-level fit:
1.5 %, exact there as that level is stuck, i.e. linear).

Measured: on the closed-form mode (tests/test_achieved_force_modal_model.py) the share is
found 0 (1e-11 m/N) and P exact, the peak samples within 0.25 % in amplitude and 0.41 % in
damping — the peak reader's own error; with a linear mode at 100 Hz beside it (11 % of the
lowest peak) the same, with φ_f given or read from P (1.00002 for 1). The harmonic-balance
Jenkins systems (2 % noise, 8 seeds; tests/test_stepped_sine_truth.py): every level within
1.1e-3 in frequency and 1.3 % in damping (SDOF), 3.6e-4 and 1.8 % (2-DOF), against 8.8e-4 /
1.1 % and 2.9e-4 / 1.5 % with the lowest level's fit (exact there: that level is stuck);
noise-free the SDOF's level whose lines cross the stick–slip kink (0.98–1.96 a_s) 6.2e-4 in
frequency (4.2e-4 before); the Iwan systems of benchmarks/test_type_truth.py, whose lowest
level is in microslip: SDOF 5.5e-4 / 3.7 % (8.9e-4 / 4.2 % before), 2-DOF 2.9e-4 / 2.7 %
(3.5e-4 / 2.6 %). On the Brake–Reuss beam (tests/data/brb) P gives φ_f = 0.696
1/√kg, against the response-controlled runs' own one-mode modal constants 0.702–0.732 (runs'
|A|/P 1.02–1.11; the lowest level's one-mode fit: 0.628 with R − R_m/Ω², 0.688 with R alone),
and the share runs from +2.1 to −8.7 µm/N (real part) over 79.2–81.2 Hz, where the runs' own
fits put it at −4 … −9 µm/N.
On the bolted T-beam example (tests/test_bolted_beam_example.py, an FE model with an Iwan
joint at its tip, 1 % noise, 3 seeds) P gives φ_f = 2.77 1/√kg against the FE shape's
2.794 (the lowest level's one-mode fit: 2.63).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.optimize
from numpy.typing import NDArray

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.modal_fit import fit_mode_near
from nlupdate.core.model.amplitude_modal import AmplitudeModelError
from nlupdate.core.run_cache import remembered_in_run

#: the order of each level's polynomials in a/a_max (over the whole band a level spans about
#: a decade of amplitude)
ORDER = 4
#: bounds of the fit's unknowns: R and S within half the largest peak (in hundredths of it),
#: P within a factor 2 of the one-mode fit's (a band that leaves out the resonances, e.g.
#: 79.2–80.2 Hz below the closed form's 80.2–80.3 Hz of tests/test_amplitude_band_cut.py,
#: determines neither: unbounded, the fit ran off to a damping 40 × the truth)
LIMITS = np.array([50.0, 50.0, np.log(2.0), 50.0, 50.0])
#: The fit's starts: (share, ln(P/P₀)) — no share or the one-mode fit's, with P₀ and 20 % either
#: side. The problem has separate minima: on the BRB cut to 80–80.6 Hz the start from no share at
#: P₀ ended at a scatter 29 × the smallest, or at it, as a change of 1e-15 in the misfits went
#: (tests/test_level_residual.py); the two starts at P₀ ± 20 % reach the smallest either way. A noisy
#: copy of data already fitted starts from that fit's end alone instead (:func:`level_residual`'s ``start``).
STARTS = (("none", 0.0), ("none", 0.2), ("none", -0.2), ("one-mode", 0.0))
#: an unknown whose end is within this fraction of :data:`LIMITS` of the box's edge is on its bound:
#: the band's lines do not determine it (the BRB cut to 80–80.6 Hz: the slope's imaginary part at −50)
BOUND_FRACTION = 0.01
#: the unknowns :attr:`LevelResidual.at_bound` names, each with the indices of its parts in the fit's x
UNKNOWNS = (("R", (0, 1)), ("ln P", (2,)), ("S", (3, 4)))
_WORDS = {"R": "the other modes' share R", "S": "the share's slope S (its change across the band)",
          "ln P": "the modal constant P"}


@dataclass(frozen=True)
class LevelResidual:
    """The other modes' share R + S·(f²/f_c² − 1) (complex R and S in receptance units, the
    same at every level; ``centre_hz`` f_c), the mode's real modal constant ``modal_constant``
    P = φ_rφ_f (receptance × rad²/s²) and the weighted scatter (sum of squares, in units of
    the relative noise of H) of the lines about their levels' curves at that share and P."""

    residual: complex
    slope: complex
    centre_hz: float
    modal_constant: float
    scatter: float
    #: the unknowns ("R", "ln P", "S") that ended within :data:`BOUND_FRACTION` of their box
    #: :data:`LIMITS`: the band's lines do not determine them (:func:`bound_warning`)
    at_bound: tuple[str, ...] = ()
    #: the lowest and highest line (Hz) the fit read
    band_hz: tuple[float, float] = (float("nan"), float("nan"))

    def receptance(self, frequency_hz: NDArray) -> NDArray[np.complex128]:
        """The other modes' share (receptance units) at ``frequency_hz`` (Hz)."""
        f = np.asarray(frequency_hz, dtype=float)
        return self.residual + self.slope * (f**2 / self.centre_hz**2 - 1) + 0j

    def about(self, centre_hz: float) -> tuple[complex, complex]:
        """(R′, S′): the same share written about another centre f_c′ (Hz), R′ + S′(f²/f_c′² − 1)
        = R + S(f²/f_c² − 1) at every f: R′ the share at f_c′, S′ = S·f_c′²/f_c²."""
        return complex(self.receptance(np.array([centre_hz]))[0]), self.slope * (centre_hz / self.centre_hz) ** 2


def _level_misfits(amplitude: NDArray, stiffness: NDArray, omega: NDArray, order: int) -> NDArray[np.float64]:
    """One level's misfits of ``Re D + Ω²`` (= ω(a)²) and ``Im D`` (= 2ζ(a)ω(a)²) about their
    weighted least-squares polynomials of ``order`` in a/a_max, each over |D| (the noise of D
    is |D| times H's relative noise)."""
    design = (amplitude / np.max(amplitude))[:, None] ** np.arange(order + 1)[None, :]
    weight = 1 / np.abs(stiffness)
    values = np.column_stack([stiffness.real + omega**2, stiffness.imag])
    coefficients = np.linalg.lstsq(design * weight[:, None], values * weight[:, None], rcond=None)[0]  # both at once
    return ((values - design @ coefficients) * weight[:, None]).ravel(order="F")


def level_residual(data: FRFLevels, modal_constant: float, start_residual: complex, centre_hz: float,
                   half_band: float, start: LevelResidual | None = None) -> LevelResidual:
    """R, S and P of ``data``'s mode (module docstring) from every line within
    ``centre_hz·(1 ± half_band)`` of every level, from the :data:`STARTS`: no share or
    ``start_residual`` (a one-mode fit's share at the centre), P = ``modal_constant`` (its
    sign is kept) or 20 % either side; the end with the smallest scatter is taken.

    With ``start`` (another fit's end, e.g. the clean data's where ``data`` is a noisy copy of
    them: :func:`~nlupdate.core.identification.band_dependence.band_changes`) the fit starts
    from that end alone — its share restated about ``centre_hz`` (the same line
    R + S·(f²/f_c² − 1)) and its |P| — and ends at the minimum nearest it, not at the smallest
    of the :data:`STARTS`' ends."""
    curves = []
    for level, f, h in zip(data.levels, data.frequencies, data.receptances):
        band = np.abs(f - centre_hz) <= half_band * centre_hz
        if np.count_nonzero(band):
            curves.append((f[band], h[band], np.asarray(data.force_at(float(level), f[band]), dtype=float)))
    unit = 1e-2 * max(float(np.max(np.abs(h))) for _, h, _ in curves)

    def share(x: NDArray) -> LevelResidual:
        return LevelResidual(unit * complex(x[0], x[1]), unit * complex(x[3], x[4]), centre_hz,
                             modal_constant * float(np.exp(x[2])), 0.0)

    def misfits(x: NDArray) -> NDArray[np.float64]:
        trial = share(x)
        out = []
        for f, h, force in curves:
            modal = h - trial.receptance(f)
            out.append(_level_misfits(np.abs(modal) * force, trial.modal_constant / modal, 2 * np.pi * f, ORDER))
        misfit = np.concatenate(out)
        return np.where(np.isfinite(misfit), misfit, 1e6)

    starts = []
    if start is None:
        for share_start, log_p in STARTS:
            r = complex(start_residual) if share_start == "one-mode" else 0j
            starts.append([r.real / unit, r.imag / unit, log_p, 0.0, 0.0])
    else:  # the same share written about this fit's centre
        r, s = start.about(centre_hz)
        starts.append([r.real / unit, r.imag / unit, np.log(abs(start.modal_constant / modal_constant)),
                       s.real / unit, s.imag / unit])
    ends = []
    for x0 in starts:
        fit = scipy.optimize.least_squares(misfits, np.clip(x0, -0.99 * LIMITS, 0.99 * LIMITS), bounds=(-LIMITS, LIMITS))
        ends.append((2 * float(fit.cost), fit.x))
    scatter, x = min(ends, key=lambda end: end[0])
    on_edge = np.abs(x) >= (1 - BOUND_FRACTION) * LIMITS
    lines = np.concatenate([f for f, _, _ in curves])
    return replace(share(x), scatter=scatter, band_hz=(float(lines.min()), float(lines.max())),
                   at_bound=tuple(name for name, parts in UNKNOWNS if np.any(on_edge[list(parts)])))


def bound_warning(share: LevelResidual) -> str | None:
    """One line saying which of ``share``'s unknowns ended on the fit's box (the lines it was
    read from do not determine them: too narrow a band, or curves one mode and a linear share
    do not hold — the fit cannot tell which) and what to do; None when none did."""
    if not share.at_bound:
        return None
    named = " and ".join(_WORDS[name] for name in share.at_bound)
    them = "them" if len(share.at_bound) > 1 else "it"
    return (f"the other modes' share and modal constant read from every line of every level between {share.band_hz[0]:.5g} "
            f"and {share.band_hz[1]:.5g} Hz end with {named} on the bound of the fit's box: the lines do not determine "
            f"{them} — too narrow a band, or curves that one mode and a linear share do not hold (a neighbouring mode, "
            f"a nonlinearity beyond the single-mode form) — and the samples, damping ratios and linear limit read with "
            f"{them} are one of many that fit; keep a wider band (both flanks of the resonance at every level) where "
            "the file has one")


@remembered_in_run  # every model, refit and sample of one validation that keeps these levels
def frf_residual(data: FRFLevels, near_hz: float | None = None, band_fraction: float = 0.1,
                 start: LevelResidual | None = None) -> tuple[float, LevelResidual]:
    """(the mode's centre (Hz), its other modes' share and modal constant from every level:
    :func:`level_residual`) for the mode near
    ``near_hz`` (default: the lowest level's peak), started from a one-mode fit of the
    lowest level over ``near_hz·(1 ± band_fraction)``, which also gives the centre — or, with
    ``start``, from that end alone (:func:`level_residual`)."""
    f_low, h_low = data.frequencies[0], data.receptances[0]
    near = float(f_low[np.argmax(np.abs(h_low))]) if near_hz is None else float(near_hz)
    fit = fit_mode_near(f_low, h_low, near, band_fraction=band_fraction)
    centre = float(fit.natural_frequencies_hz[0])
    driving = data.response_dof == data.input_dof
    constant = complex(fit.modal_constants[0])
    if not (constant.real > 0 if driving else constant.real != 0):
        raise AmplitudeModelError(f"the one-mode fit of the {data.levels[0]:g} {data.reference_unit} FRF "
                                  f"({data.response_dof}/{data.input_dof}) gives a modal constant {constant:.4g}"
                                  + (": no driving-point resonance to take φ_f from (a driving point's is positive: a "
                                     "sensor or force along the negative direction is stated as NODE:-DIR in the "
                                     "coordinates, e.g. [\"acc3:-y\", \"acc3:y\"]; or give input_shape)" if driving
                                     else ": no resonance of this mode to sample"))
    start_residual = complex(fit.residual_receptance(np.array([centre]))[0])
    return centre, level_residual(data, constant.real, start_residual, centre, 2.5 * band_fraction, start)
