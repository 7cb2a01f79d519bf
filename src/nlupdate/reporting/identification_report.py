"""The identification section of a study's report: the fit, its uncertainty, the extracted
linear FRF and its modes (method-specific wording from
:data:`~nlupdate.core.identification.methods.METHODS`)."""
from __future__ import annotations

from typing import Mapping

import pandas as pd

from nlupdate.core.identification.methods import METHODS
from nlupdate.reporting.coverage import AMPLITUDE_GAP_RATIO, covered_intervals, describe_intervals
from nlupdate.reporting.markdown import markdown_table, number


def _untrustworthy_lines(ident) -> list[str]:
    """The failed placement check (:mod:`nlupdate.core.identification.consistency`) in bold, first."""
    return [f"**{w.message}**" for w in ident.warnings if w.kind == "levels_disagree"] + \
        ([""] if not ident.trustworthy else [])


def identification_section(ident, truth: Mapping[str, float], plots: Mapping[str, str]) -> list[str]:
    s = ident.settings
    r = ident.result
    lines = ["## Identification", ""] + _untrustworthy_lines(ident) + [METHODS[s.method].describe_fit(r, ident.reference_unit)]
    if ident.frequency_choice is not None:  # the method fits at one excitation frequency, chosen by the program
        choice = ident.frequency_choice
        final = ""
        nearest = None if choice.linear_natural_frequency_hz is None else \
            ident.nearest_mode(choice.linear_natural_frequency_hz)
        if nearest is not None:
            final = (f"; identified at {r.setup.frequency_hz:g} Hz, the extracted FRF puts that mode at "
                     f"{number(ident.natural_frequencies_hz[nearest])} ± "
                     f"{number(ident.natural_frequency_std_hz[nearest], 2)} Hz (table below)")
        lines += [f"Why this frequency: {choice.reason} (visited "
                  f"{', '.join(f'{f:g}' for f in choice.visited_hz)} Hz{final}). The identification is "
                  f"most accurate near a resonance of the *linear* structure; the low-force resonance is not one, "
                  f"because the stuck friction stiffens it."]
    lines += ["", f"Noise level {100 * ident.noise_fraction:.3g} % ({ident.noise_source}). "
                  + monte_carlo_note(ident.uncertainty), ""]
    stats = ident.uncertainty.parameters
    diverged = ident.diverged  # no estimate: what the number means stands in its place
    rows = [{"parameter": name, "unit": ident.unit_of(name) or "–",
             "value": diverged.get(name, st.value),
             "Monte-Carlo std": "–" if name in diverged else st.std,
             "95 % interval": "none (diverged)" if name in diverged else
                              f"[{number(st.ci95[0])}, {number(st.ci95[1])}]"
                              + (f" (one-sided: {st.bound.why})" if st.bound is not None else ""),
             **({"truth": truth.get(name, float("nan"))} if truth else {})}
            for name, st in stats.items() if name in ident.parameters()]
    lines += [markdown_table(pd.DataFrame(rows)), "",
              "The 95 % interval holds the value: the Monte-Carlo deviations reflected about it (basic bootstrap), "
              "widened by the spread of refits with one level left out when the fit's residual is above the noise "
              "(model-form error), one-sided for a value on a limit (docs/methods.md §4, Intervals).", ""]
    if "fit" in plots:
        covered = covered_intervals(r.amplitude)
        gaps = (f", dashed across the gap{'s' if len(covered) > 2 else ''} between them (no point within a factor "
                f"{AMPLITUDE_GAP_RATIO:g} in amplitude: an interpolation no measurement checks)" if len(covered) > 1
                else "")
        lines += [f"![{s.method.upper()} fit]({plots['fit']})", "",
                  f"The points are the data ({len(r.amplitude)} of them, coloured by force level), the line the fitted "
                  f"model, solid where the data lie ({describe_intervals(covered)}){gaps} and dotted beyond them: an "
                  f"extrapolation no measurement supports, though predictions at other levels and frequencies use it. "
                  f"Grey regions hold no data. The shaded band holds 95 % of the Monte-Carlo fits; where the legend "
                  f"calls it narrower than the line, the fits agree within the line's width there. Right: "
                  f"each point's misfit in units of its noise (about 1 where the model fits).", ""]
    if ident.modes:
        rows = [{"mode": i + 1, "natural frequency (Hz)": stats[f"linear_f{i + 1}_hz"].value,
                 "std (Hz)": stats[f"linear_f{i + 1}_hz"].std, "loss factor": stats[f"linear_eta{i + 1}"].value,
                 "std": stats[f"linear_eta{i + 1}"].std} for i in range(len(ident.modes))]
        lines += [f"The extracted linear FRF (from {ident.linear_source}) has these modes "
                  f"(one-mode fits over ±{100 * s.modal_band_fraction:g} % around each resonance):", "",
                  markdown_table(pd.DataFrame(rows)), ""]
    if "linear_frf" in plots:
        combined = len(ident.linear_from_levels_n) > 1
        lines += [f"![extracted linear FRF]({plots['linear_frf']})", "",
                  f"The extracted linear FRF (red, from {ident.linear_source}) with the band holding 95 % of the "
                  f"Monte-Carlo extractions, the one-mode fits (dashed) and the {ident.linear_from_level_n:g} "
                  f"{ident.reference_unit} measurement (grey); right, around each mode (a few half-power bandwidths, within "
                  f"the frequencies the FRF covers). Where the legend calls the band narrower than the line, the "
                  f"extractions agree within the line's width. "
                  + ("Each level gives 1/H_L = 1/H − ν(|X|); near a linear resonance a level that the nonlinearity "
                     "stiffens (a stuck joint) subtracts two nearly equal dynamic stiffnesses and carries much more "
                     "noise than one near its own resonance, so the levels are weighted by their noise line by line. "
                     "Where" if combined else
                     "Near a resonance of the linear structure the extraction subtracts two nearly equal dynamic "
                     "stiffnesses (1/H_L = 1/H_1 − Δ_f1), so the noise grows there: where")
                  + " the band is wide, the modes' values and every FRF comparison against this curve carry that "
                    "uncertainty.", ""]
    return lines


def monte_carlo_note(uncertainty) -> str:
    """What the Monte-Carlo sample count means, how many failed and why."""
    n, failed = uncertainty.n_samples, uncertainty.n_failed
    text = (f"Uncertainty: {n} Monte-Carlo samples — the measured curves perturbed {n} times with fresh noise of "
            f"that level and identified again (excitation frequency or band, force levels and model held fixed); the std below is "
            f"the spread of the {n - failed} results, and the intervals and the plots' bands are built from them")
    if not failed:
        return text + " (none failed)."
    grouped = uncertainty.failure_reasons()  # one reason, whatever the numbers in parentheses
    reasons = "; ".join(f"{count} × {reason}" for reason, count in grouped[:3])
    more = len(grouped) - 3
    reasons += f"; {more} other reason{'s' if more > 1 else ''}" if more > 0 else ""
    return (text + f". {failed} sample{'s' if failed > 1 else ''} failed and {'are' if failed > 1 else 'is'} left "
            f"out as a whole ({reasons}): these are the perturbed data hardest to identify, so the ± of what "
            f"failed there may be understated.")
