"""Issue 37's time-integration truth table: every test type of an SDOF and a 2-DOF, each with a
Jenkins and an Iwan joint, with 2 % noise, over seeds; and the joint fit with each type held out.

    python benchmarks/test_type_truth.py [--seeds 8] [--backbone polynomial|iwan|jenkins] [--kink 1.5 [--kink-below 1.03] [--kink-inside]]
                                         [--at-samples] [--extra-level 1.3] [--stepped-sine lines|peaks]
                                         [--ring-down decay|segments] [--ring-down-own curve|samples]
                                         [--levels N] [--span LOW HIGH]

Systems, records and truth: tests/test_test_type_truth.py (RK4 ring-downs and taps, the
closed-form single-nonlinear-mode backbone). Per test type and seed:

* ring-down: RK4 from 30 × the Jenkins slip amplitude (Iwan: 3 ×; the 2-DOF's 240 × until
  2026-11-29), white noise 2 % of the record's peak, read by the decay fit (``fit_decay``: its
  samples where the damping is known to 1.5 %) or, with ``--ring-down segments``, in segments
  (``decay_segments``); its own fit is made on the decay fit's curve over its samples' range
  (``CURVE_POINTS``; ``--ring-down-own samples``: on the samples);
* impact: an RK4 tap (Jenkins stuck, 0.5 × slip; Iwan 0.05 ×), 2 % noise, ``fit_linear_limit``;
* phase resonance: multi-harmonic balance (5 harmonics) at 90°, at sixteen levels over 0.3–6 × a_s
  on every system (``ISSUE_LEVELS``, ``ISSUE_SPAN``): an Iwan joint from microslip to 3.3 × φ_max,
  a Jenkins joint from stuck across its kink (``--levels 6``: the Iwan systems' six of
  ``IWAN_LEVELS``, and ``--levels 6 --span 0.5 15`` the Jenkins systems' six, the designs until
  2026-11-29; the 2-DOF Iwan's were 12–240 ×, all macroslip, before that); 2 % noise on the
  force and on the response amplitude;
* force-controlled stepped sine: multi-harmonic-balance FRFs at the same levels on 301
  lines over 0.9–1.05 f₀ (``stepped_sine_table``, tests/test_stepped_sine_truth.py), 2 % noise
  (``add_table_noise``), one sample per level (``samples_from_frfs``); with ``--backbone jenkins``
  every fit that includes the stepped sine is refined on its lines (``refine_on_lines``, the
  lines within half their level's peak; ``--stepped-sine peaks``: not, as before).

Printed per system × type (with ``--kink``: off the band, then in it, from the same fits):
the largest error of the samples themselves and of that type's own
fitted backbone (``--backbone``, at 60 amplitudes over the range its samples cover), over
the seeds; then the joint fit of all types (each weighted by its own noise, as ``nlupdate
amplitude`` does) over all samples' range ("joint") and over each type's own range only
("joint, covered": without the gaps between types — e.g. each Iwan system's impact at
0.025 a_s below its other types from 0.3 a_s), and, with each type held out, the model fitted to
the others at the held-out samples' amplitudes within the others' range (as ``--hold-out``
does, but against the truth; the impact's one sample lies below the others and is predicted
by the fit's low-amplitude end) — all against the truth.
With ``--backbone jenkins`` a Jenkins system's lines end with every fit's slip amplitude
against a_s (mean ± sd over the seeds, largest): next to the kink the damping is off by up to
12.7 × that (docs/ring-down.md, "Near the stick–slip kink").
"""
from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_backbone_forms import locked_points  # noqa: E402
from test_stepped_sine_truth import IWAN_LEVELS, stepped_sine_table  # noqa: E402
from test_test_type_truth import SYSTEMS, band, free_decay, noisy, system, truth  # noqa: E402

from nlupdate.core.identification.amplitude_modal_fit import fit_amplitude_model  # noqa: E402
from nlupdate.core.identification.backbone_samples import join_samples, own_fit_for, source_noise  # noqa: E402
from nlupdate.core.identification.data import FRFLevels  # noqa: E402
from nlupdate.core.identification.decay_fit import fit_decay  # noqa: E402
from nlupdate.core.identification.impact import decay_segments, fit_linear_limit  # noqa: E402
from nlupdate.core.identification.line_refine import SteppedSineLines, refine_on_lines, stepped_sine_lines  # noqa: E402
from nlupdate.core.identification.modal_samples import ModalSamples, samples_from_frfs  # noqa: E402
from nlupdate.core.identification.phase_resonance import PhaseResonancePoints, samples_from_phase_resonance  # noqa: E402
from nlupdate.core.identification.sample_residuals import EIV_BACKBONES, sample_noise  # noqa: E402
from nlupdate.core.measurement.noise import add_table_noise  # noqa: E402

TYPES = ("ring-down", "impact", "phase-resonance", "stepped-sine")
#: the ring-down's own fit (read by the decay fit) is made on its decay curve at this many amplitudes
#: spread geometrically over its samples' range — more than the Iwan form's six unknowns, so the
#: refit follows the one fitted curve instead of being free between its two or three samples a
#: factor 1.5 apart (16 and 30 give the same within 0.1 points: docs/ring-down.md, "The ring-down's
#: own fit on its decay curve"); ``--ring-down-own samples``: on the samples, as before
CURVE_POINTS = 8
#: every system's phase-resonance and stepped-sine levels: this many spread geometrically over
#: ``ISSUE_SPAN`` × a_s (ratio 1.22: the six of ``IWAN_LEVELS`` with two more between each; one of
#: them, as one of the six, at 1.81 a_s, by the Iwan joint's φ_max = 1.8 a_s; for a Jenkins joint
#: five stuck, 0.3–0.81 a_s, one at 0.99 a_s and three over 1.2–1.8 a_s). Six cannot meet issue 37's
#: 5 % in damping on the Iwan SDOF: the Cramér–Rao bound of six points at 2 % noise puts the median
#: of its largest error over 8 seeds at 6.0 % (``kink_information.py --joint iwan --levels N``;
#: docs/ring-down.md, "More levels"). The designs until 2026-11-29: ``--levels 6`` (Iwan,
#: ``IWAN_LEVELS``) and ``--levels 6 --span 0.5 15`` (Jenkins, ``LEVELS``)
ISSUE_LEVELS = 16
ISSUE_SPAN = (float(IWAN_LEVELS[0]), float(IWAN_LEVELS[-1]))


def records(s: dict, kind: str, extra: tuple[float, ...] = (), levels: int = ISSUE_LEVELS,
            span: tuple[float, float] = ISSUE_SPAN) -> dict:
    """The noise-free records of every test type of one system (``levels`` phase-resonance and
    stepped-sine levels spread geometrically over ``span`` × a_s; ``extra``: more levels, × a_s)."""
    slip = s["slip"]
    # the Iwan ring-down from 3 a_s (1.7 φ_max: φ_max = 1.8 a_s on both systems), inside the
    # levels' span, which it decays through towards microslip
    start = (30 if kind == "jenkins" else 3) * slip
    # levels (ISSUE_LEVELS): from a Jenkins joint stuck, or an Iwan joint in microslip, to past
    # 2 × the Iwan joint's φ_max (MACROSLIP_REACH: below it an Iwan fit fixes β = 0)
    amplitude = np.sort(np.append(np.geomspace(*span, levels), extra)) * slip
    points = locked_points(s, amplitude)  # (Ω, the force that holds the amplitude at resonance, x)
    return {"decay": free_decay(s, start, 80), "tap": free_decay(s, (0.5 if kind == "jenkins" else 0.05) * slip, 40),
            "points": points, "table": stepped_sine_table(s, points[1])}


def samples(s: dict, made: dict, seed: int,
            ring_down: str = "decay") -> tuple[dict[str, tuple[ModalSamples, tuple[float, float] | None]],
                                               SteppedSineLines, ModalSamples | None]:
    """Each type's samples with 2 % noise (and the stated noise the joint fit weighs it by), the
    stepped sine's lines (the same noisy FRFs), and the ring-down's decay curve at
    :data:`CURVE_POINTS` amplitudes over its samples' range (None when read in segments)."""
    psi, rng = s["phi"][0], np.random.default_rng(1000 + seed)
    t, x = made["decay"]
    curve = None
    if ring_down == "decay":
        fit = fit_decay(t, noisy(x, seed), band(s), shape=psi)
        ring = (fit.samples(), fit.stated_noise())
        a = np.geomspace(ring[0].amplitude.min(), ring[0].amplitude.max(), CURVE_POINTS)
        f, zeta = fit.curves(a)[:2]
        curve = ModalSamples(a, f, zeta, np.zeros(a.size), fit.shape)
    else:
        parts = decay_segments(t, {"x": noisy(x, seed)}, band(s), shape=psi)
        ring = (join_samples([p.samples() for p in parts]),
                (float(np.median([p.frequency_std_hz / p.frequency_hz for p in parts])),
                 float(np.median([p.damping_std / p.damping_ratio for p in parts]))))
    t, x = made["tap"]
    tap = fit_linear_limit(t, {"x": noisy(x, seed)}, band(s), shape=psi)
    omega, force, response = made["points"]
    pr = samples_from_phase_resonance(PhaseResonancePoints(
        "pr", "m1", "m1", omega / (2 * np.pi), force * (1 + 0.02 * rng.standard_normal(force.size)),
        response * (1 + 0.02 * rng.standard_normal(force.size))), psi, psi)
    table = add_table_noise(made["table"], 0.02, seed)
    data = FRFLevels.from_table(table, str(table["response_dof"].iloc[0]), str(table["input_dof"].iloc[0]))
    frfs = samples_from_frfs(data, psi)
    return {"ring-down": ring, "impact": (tap.samples(), (tap.frequency_std_hz / tap.frequency_hz,
                                                          tap.damping_std / tap.damping_ratio)),
            "phase-resonance": (pr, None), "stepped-sine": (frfs, None)}, stepped_sine_lines(data, psi), curve


#: with ``--kink K`` (and ``--kink-below B``), amplitudes within [a_s/B, K·a_s] of the Jenkins slip
#: amplitude a_s are left out of every error (B = K unless given): just above a_s the truth's ζ(a)
#: rises from ζ₀ with ∂ln ζ/∂ln a_s = −12.7 (SDOF), so a slip amplitude 1 % off is ζ up to 13 % off
#: (docs/ring-down.md, "Near the stick–slip kink")
KINK = 1.0
KINK_BELOW = 1.0
#: the parts of the amplitudes each error is taken over: "all"; with ``--kink`` "off" the band and
#: "in" it (both from the same fits; ``--kink-inside``: "in" only)
PARTS = ("all",)


def _kept(s: dict, a: np.ndarray, part: str) -> np.ndarray:
    """Which amplitudes the errors over ``part`` ("all", "off" or "in" the kink band) take."""
    if part == "all" or KINK <= 1:
        return np.ones(a.size, bool)
    outside = (a <= s["slip"] / KINK_BELOW) | (a >= KINK * s["slip"])
    return ~outside if part == "in" else outside


def curve_errors(s: dict, model, low: float, high: float, at: np.ndarray | None = None,
                 part: str = "all") -> tuple[float, float]:
    """Largest relative errors of a fitted model against the truth over [low, high] (modal
    amplitude): at 60 amplitudes, or at the amplitudes ``at`` within it (``part``: off or in the
    band near the Jenkins slip amplitude, ``--kink``)."""
    a = np.geomspace(low, high, 60) if at is None else at[(at >= low) & (at <= high)]
    a = a[_kept(s, a, part)]
    if a.size == 0:
        return np.nan, np.nan
    f, z = truth(s, a)
    return float(np.max(np.abs(model.frequency_hz(a) / f - 1))), float(np.max(np.abs(model.damping(a) / z - 1)))


def covered_errors(s: dict, model, every: dict, part: str = "all") -> tuple[float, float]:
    """Largest relative errors of a fitted model against the truth at 60 amplitudes over each
    source's own range (the amplitudes the sources cover; the gaps between them left out)."""
    errors = [curve_errors(s, model, smp.amplitude.min(), smp.amplitude.max(), part=part)
              for smp, _ in every.values()]
    return float(np.nanmax([e[0] for e in errors])), float(np.nanmax([e[1] for e in errors]))


def sample_errors(s: dict, smp: ModalSamples, part: str = "all") -> tuple[float, float]:
    a = smp.amplitude
    keep = _kept(s, a, part)
    if not keep.any():
        return np.nan, np.nan
    f, z = truth(s, a[keep])
    return (float(np.max(np.abs(smp.frequency_hz[keep] / f - 1))),
            float(np.max(np.abs(smp.damping_ratio[keep] / z - 1))))


def slip_error(s: dict, model) -> float:
    """The fitted joint's slip amplitude φ_max over the truth's a_s, − 1 (NaN without a joint):
    near a Jenkins joint's kink the fitted damping is off by up to 12.7 × this (SDOF)."""
    joint = getattr(model, "joint", None)
    return float(joint.phi_max / s["slip"] - 1) if joint is not None else np.nan


def fit(s: dict, chosen: dict[str, tuple[ModalSamples, tuple[float, float] | None]], backbone: str,
        lines: SteppedSineLines | None = None):
    """The fit of the ``chosen`` types (each weighted by its noise, as ``nlupdate amplitude``
    does); with ``lines`` (``--stepped-sine lines``, the Jenkins backbone) and the stepped sine
    among them, refined on its lines with the other types' samples (``refine_on_lines``)."""
    shapes = (("m1", float(s["phi"][0])),)
    joined = join_samples([c[0] for c in chosen.values()])
    own_fit = own_fit_for(backbone, shapes)
    noise = [source_noise(smp, stated, own_fit) for smp, stated in chosen.values()]
    f_std, z_std, a_std = sample_noise(list(chosen), [smp.amplitude.size for smp, _ in chosen.values()], noise,
                                       backbone in EIV_BACKBONES)
    model = fit_amplitude_model(joined, shapes, backbone, 2, frequency_std=f_std, damping_std=z_std,
                                amplitude_std=a_std)
    if lines is None or backbone != "jenkins" or "stepped-sine" not in chosen:
        return model
    names = [n for n in chosen if n != "stepped-sine"]
    if not names:
        return refine_on_lines(model, lines)[0]
    others = join_samples([chosen[n][0] for n in names])
    keep = np.concatenate([np.full(smp.amplitude.size, n != "stepped-sine") for n, (smp, _) in chosen.items()])
    # the refinement takes the other sources' samples at their amplitudes and own noise, as
    # nlupdate amplitude does (amplitude_joint._refined), not the sample fit's locked frequencies
    f_std, z_std, _ = sample_noise(list(chosen), [smp.amplitude.size for smp, _ in chosen.values()], noise, False)
    return refine_on_lines(model, lines, others, f_std[keep], z_std[keep])[0]


def seed_rows(s: dict, every: dict[str, tuple[ModalSamples, tuple[float, float] | None]],
              lines: SteppedSineLines | None, curve: ModalSamples | None, backbone: str,
              at_samples: bool = False) -> tuple[dict[str, dict[str, tuple[float, ...]]], dict[str, float]]:
    """One seed's errors against the truth (module docstring): per part of the amplitudes
    (:data:`PARTS`) and per type (and "joint", "joint, covered") the row (samples f, ζ; own fit
    f, ζ; lowest and highest amplitude × a_s; held out f, ζ), relative and NaN where there is
    none; and each fit's slip error (:func:`slip_error`). ``curve``: the ring-down's own fit is
    made on it (:data:`CURVE_POINTS`) instead of its samples."""
    rows: dict[str, dict[str, tuple[float, ...]]] = {part: {} for part in PARTS}
    slips = {}
    for name, (smp, stated) in every.items():
        on = curve if name == "ring-down" and curve is not None else smp
        own_model = fit(s, {name: (on, stated)}, backbone, lines) if on.amplitude.size >= 3 else None
        rest = {other: every[other] for other in TYPES if other != name}
        model = fit(s, rest, backbone, lines)
        slips[f"own {name}"], slips[f"without {name}"] = slip_error(s, own_model), slip_error(s, model)
        low = max(smp.amplitude.min(), min(r[0].amplitude.min() for r in rest.values()))
        if name == "impact":  # the linear limit lies below every other type: the models' a → 0 end
            low = smp.amplitude.min()
        high = min(smp.amplitude.max(), max(r[0].amplitude.max() for r in rest.values()))
        for part in PARTS:
            own = (curve_errors(s, own_model, smp.amplitude.min(), smp.amplitude.max(),
                                smp.amplitude if at_samples else None, part)
                   if own_model is not None else (np.nan, np.nan))
            held = curve_errors(s, model, low, high, smp.amplitude, part) if low <= high else (np.nan, np.nan)
            rows[part][name] = (*sample_errors(s, smp, part), *own, smp.amplitude.min() / s["slip"],
                                smp.amplitude.max() / s["slip"], *held)
    joined = join_samples([smp for smp, _ in every.values()])
    model = fit(s, every, backbone, lines)
    slips["joint"] = slip_error(s, model)
    span = (joined.amplitude.min() / s["slip"], joined.amplitude.max() / s["slip"])
    for part in PARTS:
        rows[part]["joint"] = (np.nan, np.nan, *curve_errors(s, model, joined.amplitude.min(),
                                                             joined.amplitude.max(), part=part),
                               *span, np.nan, np.nan)
        rows[part]["joint, covered"] = (np.nan, np.nan, *covered_errors(s, model, every, part), *span, np.nan, np.nan)
    return rows, slips


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--backbone", default="polynomial", choices=("polynomial", "iwan", "jenkins"))
    parser.add_argument("--system", action="append", choices=[f"{d}-{k}" for d, k in SYSTEMS],
                        help="only these systems (repeatable; default all)")
    parser.add_argument("--kink", type=float, default=1.0, metavar="K",
                        help="leave out amplitudes within [a_s/K, K·a_s] of the Jenkins slip amplitude a_s")
    parser.add_argument("--kink-below", type=float, default=None, metavar="B",
                        help="with --kink: leave out [a_s/B, K·a_s] instead (B > 1; default K)")
    parser.add_argument("--ring-down", default="decay", choices=("decay", "segments"),
                        help="how the ring-down is read: the decay fit (default) or segments")
    parser.add_argument("--extra-level", type=float, action="append", default=[], metavar="X",
                        help="one more phase-resonance and stepped-sine level at X × a_s (repeatable)")
    parser.add_argument("--ring-down-own", default="curve", choices=("curve", "samples"),
                        help="the ring-down's own fit (decay fit) on its decay curve at CURVE_POINTS amplitudes over "
                             "its samples' range (default) or on its samples a factor 1.5 apart (as before 2026-11-29)")
    parser.add_argument("--levels", "--iwan-levels", type=int, default=ISSUE_LEVELS, metavar="N",
                        help="every system's phase-resonance and stepped-sine levels: N spread geometrically over "
                             "--span (default ISSUE_LEVELS, 16; the designs until 2026-11-29: 6, and for the "
                             "Jenkins systems 6 with --span 0.5 15)")
    parser.add_argument("--span", type=float, nargs=2, default=ISSUE_SPAN, metavar=("LOW", "HIGH"),
                        help="the levels' span × a_s (default ISSUE_SPAN, 0.3 6)")
    parser.add_argument("--kink-inside", action="store_true",
                        help="with --kink: only the amplitudes within the band (default: off it, then in it)")
    parser.add_argument("--stepped-sine", default="lines", choices=("lines", "peaks"),
                        help="with --backbone jenkins: refine every fit with the stepped sine on its lines (default) "
                             "or fit its peaks only (one sample per level, as before)")
    parser.add_argument("--at-samples", action="store_true",
                        help="each type's own fit at its samples' amplitudes instead of 60 over their range")
    args = parser.parse_args()
    global KINK, KINK_BELOW, PARTS
    KINK = args.kink
    KINK_BELOW = args.kink if args.kink_below is None else args.kink_below
    PARTS = ("all",) if KINK <= 1 else ("in",) if args.kink_inside else ("off", "in")
    print(f"{'system':16s} {'type':16s} {'samples f':>9s} {'samples ζ':>9s} {'own fit f':>9s} {'own fit ζ':>9s} "
          f"{'a/slip':>12s}   held out: f, ζ")
    for dofs, kind in SYSTEMS:
        if args.system and f"{dofs}-{kind}" not in args.system:
            continue
        s, started = system(dofs, kind), time.process_time()
        made = records(s, kind, tuple(args.extra_level), args.levels, tuple(args.span))
        rows = {(part, name): [] for part in PARTS for name in TYPES + ("joint", "joint, covered")}
        slips: dict[str, list[float]] = {}
        for seed in range(args.seeds):
            every, lines, curve = samples(s, made, seed, args.ring_down)
            errors, slip = seed_rows(s, every, lines if args.stepped_sine == "lines" else None,
                                     curve if args.ring_down_own == "curve" else None, args.backbone, args.at_samples)
            for part, named in errors.items():
                for name, row in named.items():
                    rows[part, name].append(row)
            for name, value in slip.items():
                slips.setdefault(name, []).append(value)
        for (part, name), values in rows.items():
            v = np.array(values, dtype=float)
            label = {"all": name, "off": f"{name}, off kink", "in": f"{name}, in kink"}[part]
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                worst = [np.nanmax(v[:, j]) if np.isfinite(v[:, j]).any() else np.nan for j in range(v.shape[1])]
            print(f"{dofs}-DOF {kind:10s} {label:16s} {worst[0]:9.1e} {worst[1]:9.3f} {worst[2]:9.1e} {worst[3]:9.3f} "
                  f"{np.nanmin(v[:, 4]):5.3g}–{np.nanmax(v[:, 5]):5.3g}   {worst[6]:.1e}, {worst[7]:.3f}")
        if kind == "jenkins" and args.backbone == "jenkins":
            print("  fitted slip amplitude / a_s − 1, mean ± sd (largest |.|): " + "; ".join(
                f"{name} {np.nanmean(v):+.4f} ± {np.nanstd(v, ddof=1):.4f} ({np.nanmax(np.abs(v)):.4f})"
                for name, v in ((n, np.array(e, dtype=float)) for n, e in slips.items()) if np.isfinite(v).any()))
        print(f"  ({args.seeds} seeds, {time.process_time() - started:.0f} s CPU)", flush=True)


if __name__ == "__main__":
    main()
