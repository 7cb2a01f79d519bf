"""One backbone figure and one damping figure of ``nlupdate amplitude``: every source's
samples marked (a source that disagrees with the joint fit says so in the legend; a source
held out, grey and filled), the jointly fitted curve and its bootstrap band (``backbone.csv``), grey where the curve has no
samples (extrapolated, or held at its value beyond the largest amplitude), the legend below
the axes."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from nlupdate.core.identification.backbone_samples import TEST_TYPES
from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.core.model.amplitude_modal import AmplitudeModalModel
from nlupdate.reporting.figures import EXTRAPOLATION_FILL, band_fill, label_thin_bands, save_figure
from nlupdate.reporting.model_numbers import damping_text, linear_limit_text
from nlupdate.reporting.styles import COLOURS

_MARKERS = "os^vDP*Xh<>"


def modal_amplitude_unit(reference_unit: str = "N") -> str:
    """The unit of a modal amplitude a = x/φ: m·√kg for a mass-normalised shape φ (1/√kg) of
    FRFs per newton; per volt (``reference_unit`` "V": FRFs in m/V, φ² in 1/kg · N/V) a is
    in m·√(kg·V/N), which a reader of "m·√kg" would take for a physical modal amplitude."""
    return "m·√kg" if reference_unit == "N" else f"m·√(kg·{reference_unit}/N)"


def model_title(model: AmplitudeModalModel) -> str:
    """A figure's title: the linear limit, and — when the fit warns about it (extrapolated
    below every sample, on a bound, a stiffening backbone) — that the numbers are not
    determined by the samples, so the title does not read as a confident answer the
    terminal contradicts."""
    title = f"mode {model.mode}: {linear_limit_text(model, 5)}, ζ₀ = {damping_text(model, 3)}"
    if model.warnings:
        title += "\nNOT determined by the samples: see the warnings (terminal, amplitude_model.json)"
    return title


def _source_styles(names: list[str]) -> dict[str, tuple[str, str]]:
    """Source name ("FILE (test-type)") → (marker, colour), ordered by test type and name, not
    by the source's place among the fitted ones: a source keeps its look whichever other source
    is held out (the impact was an orange square beside the ring-down, a blue circle with the
    ring-down held out)."""
    def key(name: str) -> tuple[int, str]:
        kind = name.rsplit("(", 1)[-1].rstrip(")")
        return (TEST_TYPES.index(kind) if kind in TEST_TYPES else len(TEST_TYPES), name)
    return {name: (_MARKERS[k % len(_MARKERS)], COLOURS[k % len(COLOURS)])
            for k, name in enumerate(sorted(set(names), key=key))}


def _short(name: str) -> str:
    return Path(name.split(",")[0]).name + (" …" if "," in name else "")


def plot_sources(model: AmplitudeModalModel, parts: list[tuple[str, ModalSamples]], curve: pd.DataFrame,
                 folder: Path, disagreeing: frozenset[str] = frozenset(),
                 held: list[tuple[str, ModalSamples]] = ()) -> tuple[Path, Path]:
    """``folder/backbone.png`` (natural frequency) and ``folder/damping.png`` (damping ratio)
    against modal amplitude: each source's samples with its own marker (the sources named
    in ``disagreeing`` marked so in the legend), the ``held`` sources (held out of the fit)
    filled grey, the model over a third of the smallest to three times the largest amplitude,
    grey beyond the fitted samples, its band where ``curve`` (backbone.csv) has one (its
    legend saying when it is narrower than the line)."""
    amplitudes = np.concatenate([s.amplitude for _, s in parts])
    every = np.concatenate([amplitudes, *[s.amplitude for _, s in held]])
    a = np.geomspace(every.min() / 3, every.max() * 3, 300)
    styles = _source_styles([source for source, _ in [*parts, *held]])
    paths = []
    for column, scale, label, name in (("natural_frequency_hz", 1.0, "natural frequency (Hz)", "backbone.png"),
                                       ("damping_ratio", 100.0, "damping ratio (%)", "damping.png")):
        fig = Figure(figsize=(8.5, 5.4), layout="constrained")
        ax = fig.subplots()
        for source, samples in parts:
            values = samples.frequency_hz if column == "natural_frequency_hz" else samples.damping_ratio
            odd = " — DISAGREES with the fit" if source in disagreeing else ""
            marker, colour = styles[source]
            ax.semilogx(samples.amplitude, scale * values, marker, ms=5, mfc="none", color=colour, zorder=3,
                        label=f"{_short(source)}: {samples.amplitude.size} sample(s){odd}")
        for source, samples in held:
            values = samples.frequency_hz if column == "natural_frequency_hz" else samples.damping_ratio
            ax.semilogx(samples.amplitude, scale * values, styles[source][0], ms=5, color="0.45", zorder=3,
                        label=f"{_short(source)}: {samples.amplitude.size} sample(s), held out (not fitted)")
        fitted = model.frequency_hz(a) if column == "natural_frequency_hz" else model.damping(a)
        ax.semilogx(a, scale * fitted, "-", color="black", lw=1.2, zorder=2,
                    label=f"{model.backbone} fit, " + ("the sources not held out" if held else "all sources"))
        low, high = curve[f"{column}_low"].to_numpy(), curve[f"{column}_high"].to_numpy()
        if np.all(np.isfinite(low)) and np.all(np.isfinite(high)):
            band_fill(ax, curve["modal_amplitude"], scale * low, scale * high, "95 % band of the fit (bootstrap)",
                      color="tab:blue", alpha=0.2, zorder=1)
        else:  # say so: a curve without a band reads as a certain one
            ax.plot([], [], " ", label="no 95 % band (no bootstrap refits: --bootstrap N)")
        ax.axvspan(a[0], amplitudes.min(), **EXTRAPOLATION_FILL, label="no samples (extrapolated or held)")
        ax.axvspan(amplitudes.max(), a[-1], **EXTRAPOLATION_FILL)
        ax.set_xlim(a[0], a[-1])
        ax.set_xlabel(f"modal amplitude a ({modal_amplitude_unit(model.reference_unit)})"
                      if all(s.modal for _, s in parts) else
                      "amplitude at the record's channel (m; no --shape given: not modal)")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
        ax.set_title(model_title(model), fontsize=10, color="firebrick" if model.warnings else "black")
        label_thin_bands(fig)
        fig.legend(loc="outside lower center", ncols=2, fontsize=7, frameon=False)
        paths.append(save_figure(fig, folder / name))
    return paths[0], paths[1]
