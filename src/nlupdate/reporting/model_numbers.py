"""An amplitude-dependent modal model's numbers as the terminal, the figures' titles and the
study summary print them: a parameter the fit left on one of its bounds is named so, with the
side the samples would take it to (a one-sided statement), never printed as a confident number
(issue 34 item 4: the BRB's default Iwan fit printed "linear limit 80.5512 Hz" on its upper
bound and "chi = -1e-09" on its bound 0; the transmitter beam's polynomial fit printed ζ₀ =
"1.377e-20 %" at its bound 0). Renders only: the bounds are the fit's
(:mod:`nlupdate.core.identification.linear_limit`, :class:`~nlupdate.core.model.elements.IwanJoint`).
"""
from __future__ import annotations

from nlupdate.core.identification.linear_limit import F0_AT_UPPER_BOUND, zeta_text
from nlupdate.core.model.amplitude_modal import AmplitudeModalModel

#: a fitted χ this close to an end of (−1, 0] is on that bound (the fit works in logit(−χ))
CHI_BOUND = 1e-6


def linear_limit_text(model: AmplitudeModalModel, digits: int = 6) -> str:
    """"linear limit f₀ Hz", or — with the fit's warning that f₀ sits on its upper bound — "linear
    limit ≥ f₀ Hz (on its physical bound: …)"."""
    f0 = f"{model.natural_frequency_hz:.{digits}g} Hz"
    if any(F0_AT_UPPER_BOUND in warning for warning in model.warnings):
        return f"linear limit ≥ {f0} (on its upper physical bound: the samples do not determine it)"
    return f"linear limit {f0}"


def damping_text(model: AmplitudeModalModel, digits: int = 4) -> str:
    """The linear damping ratio ζ₀ in percent, or its bound 0 (:func:`~nlupdate.core.identification.linear_limit.zeta_text`)."""
    return zeta_text(model.damping_ratio, digits)


def joint_text(model: AmplitudeModalModel, unit: str = "N") -> str:
    """The modal Iwan joint's parameters, each on a bound named with its side: χ at 0 (the
    samples' dissipation grows at least as fast as a uniform slip-force density's) or at −1 (a
    Jenkins element), β = 0 (no macroslip stiffness), and K_T, F_S as lower bounds where the fit
    fixed β = 0 and φ_max at the largest amplitude (the model's ``lower_bounds``)."""
    j, lower = model.joint, model.lower_bounds
    kt = f"kt {'≥' if 'kt' in lower else '='} {j.kt:.6g} rad²/s²"
    slip = f"slip_force {'≥' if 'slip_force' in lower else '='} {j.slip_force:.6g} {unit}/√kg"
    if j.chi >= -CHI_BOUND:
        chi = ("chi = 0 (at its bound −1 < chi ≤ 0: the samples would take it to chi ≥ 0, a dissipation growing at "
               "least as fast as a uniform slip-force density's; not determined)")
    elif j.chi <= -1 + CHI_BOUND:
        chi = "chi = −1 (at its bound −1 < chi: a Jenkins element; not determined)"
    else:
        chi = f"chi = {j.chi:.4g}"
    beta = "beta = 0 (at its bound beta ≥ 0)" if j.beta == 0 else f"beta = {j.beta:.4g}"
    return f"{kt}, {slip}" + (" (lower bounds: beta fixed at 0, no sample reaches macroslip)" if lower else "") \
        + f", {chi}, {beta}"
