"""``nlupdate identify``: nonlinearity and linear FRF from FRFs measured at several force levels.

PRD (default) or DDF on one (response, input) pair of a measured-FRF table. Writes
``DIR/identification.json``, ``DIR/linear_frf.parquet`` (force_level_n = 0 means
"linear"), ``DIR/fit.png`` and ``DIR/linear_frf.png``; the folder is written atomically.
Every option left out is filled by a default that is printed and listed in the JSON
under ``defaults_used``.
"""
from __future__ import annotations

import argparse
import functools
from pathlib import Path

import numpy as np

from nlupdate.cli import CliError
from nlupdate.correlation.metrics import frac, natural_frequencies
from nlupdate.identification.data import FRFLevels
from nlupdate.measurement.noise import estimate_noise_fraction
from nlupdate.identification.ddf import DDF_ESTIMATORS, identify_ddf
from nlupdate.identification.dfmodels import PolynomialModel, parse_elements
from nlupdate.identification.frequency import recommend_frequency
from nlupdate.identification.modal_fit import fit_modal_model
from nlupdate.identification.prd import ESTIMATORS, identify_prd
from nlupdate.identification.report import (
    JSON_NAME, elements_summary, linear_frf_table, plot_fit, plot_linear_frf, write_directory_atomically, write_json,
)
from nlupdate.identification.uncertainty import monte_carlo
from nlupdate.measurement.frf_table import read_frf_table, write_frf_table


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "identify",
        help="identify the nonlinearity and the linear FRF (PRD or DDF method)",
        description=__doc__.splitlines()[0],
    )
    parser.add_argument("--measured", required=True, metavar="FILE", help="measured-FRF table (.parquet, .csv, .uff)")
    parser.add_argument("--method", choices=("prd", "ddf"), default="prd", help="identification method (default prd)")
    parser.add_argument("--input-dof", help="forced coordinate (default: the table's only input)")
    parser.add_argument("--response-dof", help="response coordinate of the nonlinearity (default: the input, driving point)")
    parser.add_argument("--frequency", type=float, help="PRD excitation frequency in Hz (default: recommended, see docs)")
    parser.add_argument("--low-force", type=float, help="PRD low force level in N (default: lowest level)")
    parser.add_argument("--high-forces", help="PRD high levels in N, comma-separated (default: all above the low level)")
    parser.add_argument("--elements", help="physical elements to fit, e.g. cubic,jenkins (default: polynomial)")
    parser.add_argument("--order", type=int, help="polynomial order (default 2)")
    parser.add_argument("--imag-order", type=int, help="PRD order of the imaginary part (default: --order)")
    parser.add_argument("--complex-delta-f1", action="store_true",
                        help="PRD polynomial: use the complex −y(0) as Δ_f1 (default: its real part, stuck friction)")
    parser.add_argument("--estimator", help=f"PRD: {'|'.join(ESTIMATORS)} (default improved); DDF: "
                                            f"{'|'.join(DDF_ESTIMATORS)} (default naive)")
    parser.add_argument("--half-window", type=float, default=None,
                        help="PRD improved estimator: relative half-width of the frequency window (default 0.01)")
    parser.add_argument("--smooth-linear", type=int, default=0, metavar="N",
                        help="PRD: smooth 1/H of the low-force sweep over N points (odd ≥ 5) before extracting the "
                             "linear FRF (default 0: no smoothing, as the source)")
    parser.add_argument("--amplitude-dependent-delta", action="store_true",
                        help="PRD: Δ_f1 = ν_low(|H_1(ω)|F_1) at every frequency (default: the constant Δ_f1 "
                             "identified at the excitation frequency, the source's eq. 2.55)")
    parser.add_argument("--force-pair", help="DDF levels F1,F2 in N (default: lowest and highest)")
    parser.add_argument("--band", help="DDF band LOW,HIGH in Hz (default: all common frequencies)")
    parser.add_argument("--noise-fraction", type=float,
                        help="noise std / |H| for the uncertainty (default: estimated from the lowest-force sweep)")
    parser.add_argument("--samples", type=int, default=200, help="Monte-Carlo samples for the uncertainty (default 200)")
    parser.add_argument("--seed", type=int, default=0, help="Monte-Carlo seed (default 0)")
    parser.add_argument("--out", required=True, metavar="DIR", help="output directory")
    parser.set_defaults(run=run)


def _floats(text: str, option: str, count: int | None = None) -> list[float]:
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise CliError(f"{option} {text!r}: expected comma-separated numbers") from None
    if count is not None and len(values) != count:
        raise CliError(f"{option} {text!r}: expected {count} comma-separated numbers")
    return values


def _prd_estimate(data: FRFLevels, frequency, model, low, highs, estimator, half_window):
    return identify_prd(data, frequency, model, low_force=low, high_forces=highs, estimator=estimator,
                        half_window=half_window)


def _ddf_estimate(data: FRFLevels, pair, band, order, physical, estimator):
    return identify_ddf(data, pair, band, order, physical=physical, estimator=estimator)


def run(args: argparse.Namespace) -> int:
    table = read_frf_table(args.measured)
    defaults: dict[str, object] = {}
    inputs = sorted(set(table["input_dof"].astype(str)))
    input_dof = args.input_dof
    if input_dof is None:
        if len(inputs) != 1:
            raise CliError(f"the table has several input dofs {inputs}; choose one with --input-dof")
        input_dof = defaults["input_dof"] = inputs[0]
    response_dof = args.response_dof
    if response_dof is None:
        response_dof = defaults["response_dof"] = str(input_dof)
    data = FRFLevels.from_table(table, str(response_dof), str(input_dof))
    if args.samples < 2:
        raise CliError(f"--samples must be at least 2, got {args.samples}")

    physical = parse_elements(args.elements)
    order = args.order
    if order is None:
        order = defaults["order"] = 2
    if args.method == "prd":
        summary, result, h_linear, f_linear, estimate = _run_prd(args, data, physical, order, defaults)
    else:
        summary, result, h_linear, f_linear, estimate = _run_ddf(args, data, physical, order, defaults)

    if args.noise_fraction is not None:
        if not np.isfinite(args.noise_fraction) or args.noise_fraction < 0:
            raise CliError(f"--noise-fraction must be ≥ 0, got {args.noise_fraction}")
        noise, noise_source = float(args.noise_fraction), "given (--noise-fraction)"
    else:
        f_low, h_low = data.curve(data.levels[0])
        try:
            noise = estimate_noise_fraction(f_low, h_low)
            noise_source = f"estimated from the {data.levels[0]:g} N sweep (local quadratic fits of 1/H)"
        except ValueError as error:
            if getattr(result, "noise_fraction", None) is None:
                raise CliError(f"cannot estimate the noise level ({error}); give --noise-fraction") from None
            noise, noise_source = float(result.noise_fraction), "estimated from the residuals of the fit"
        defaults["noise_fraction"] = f"{noise:.4g} ({noise_source})"
    uncertainty = monte_carlo(estimate, data, result.parameters(), noise, args.samples, args.seed)

    natural = natural_frequencies(f_linear, h_linear)
    f_ref, h_ref = data.curve(summary["linear_from_level_n"])
    try:  # noise of 1/H^L is that of the measured 1/H it was extracted from
        modal = fit_modal_model(f_linear, h_linear, inverse_noise=np.abs(1.0 / h_ref))
        modal_summary = {
            "natural_frequencies_hz": modal.natural_frequencies_hz, "loss_factors": modal.loss_factors,
            "relative_rms_error": modal.relative_rms_error,
            "definition": "H = sum_r A_r/(w_r^2 - w^2 + i eta_r w_r^2) + R fitted to the extracted linear FRF",
        }
    except (ValueError, np.linalg.LinAlgError) as error:
        modal, modal_summary = None, {"error": str(error)}
    summary.update({
        "model": (physical.description() if physical else result_model_description(result)),
        "response_dof": str(response_dof),
        "input_dof": str(input_dof),
        "parameters": {name: stats.as_dict() for name, stats in uncertainty.parameters.items()},
        "uncertainty": dict(uncertainty.as_dict(), held_fixed="excitation frequency / band, force levels and model"),
        "noise_fraction": {"value": noise, "source": noise_source},
        "elements": elements_summary(result, str(response_dof)),
        "linear_frf": {
            "file": "linear_frf.parquet",
            "from_force_level_n": summary["linear_from_level_n"],
            "natural_frequencies_hz": natural,
            "frac_vs_measured_at_that_level": frac(h_ref, h_linear),
            "modal_fit": modal_summary,
        },
        "defaults_used": defaults,
        "files": [JSON_NAME, "linear_frf.parquet", "fit.png", "linear_frf.png"],
    })
    title = f"{args.method.upper()} ({result.estimator}), response {response_dof} / input {input_dof}"
    measured_curves = [(f"{level:g} N", *data.curve(level)) for level in data.levels]

    def write(folder: Path) -> None:
        write_json(summary, folder / JSON_NAME)
        write_frf_table(linear_frf_table(f_linear, h_linear, response_dof, input_dof), folder / "linear_frf.parquet")
        plot_fit(result, folder / "fit.png", title)
        plot_linear_frf(f_linear, h_linear, measured_curves, folder / "linear_frf.png", title,
                        None if modal is None else modal.receptance(f_linear))

    out = write_directory_atomically(args.out, write)
    for key, value in defaults.items():
        print(f"default {key}: {value}")
    for name, stats in uncertainty.parameters.items():
        print(f"{name} = {stats.value:.6g} (MC mean {stats.mean:.6g} ± {stats.std:.3g}, 95 % "
              f"[{stats.ci95[0]:.6g}, {stats.ci95[1]:.6g}])")
    if modal is not None:
        print("linear natural frequencies (Hz, modal fit): "
              + ", ".join(f"{f:.3f}" for f in modal.natural_frequencies_hz)
              + "; loss factors: " + ", ".join(f"{e:.4g}" for e in modal.loss_factors))
    print(f"wrote {out / JSON_NAME} and the linear FRF, fit and FRF plots")
    return 0


def result_model_description(result) -> str:
    model = getattr(result, "model", None)
    if model is not None:
        return model.description()
    return f"DDF polynomial Δ(x) = Σ c_k x^k, k = 1..{result.setup.order}"


def _run_prd(args, data: FRFLevels, physical, order: int, defaults: dict):
    if args.force_pair or args.band:
        raise CliError("--force-pair and --band apply to --method ddf")
    model = physical or PolynomialModel.of_order(order, args.imag_order, args.complex_delta_f1)
    estimator = args.estimator
    if estimator is None:
        estimator = defaults["estimator"] = "improved"
    if estimator not in ESTIMATORS:
        raise CliError(f"--estimator {estimator!r}: PRD estimators are {', '.join(ESTIMATORS)}")
    half_window = args.half_window
    if half_window is None:
        half_window = 0.01
        if estimator == "improved":
            defaults["half_window"] = half_window
    highs = None if args.high_forces is None else _floats(args.high_forces, "--high-forces")
    low = args.low_force
    if low is None and data.levels.size:
        low = defaults["low_force_n"] = float(data.levels[0])
    if highs is None:
        defaults["high_forces_n"] = "all levels above the low force"
    frequency = args.frequency
    choice = None
    if frequency is None:
        choice = recommend_frequency(data, model, low_force=low, high_forces=highs, estimator=estimator,
                                     half_window=half_window)
        frequency = choice.frequency_hz
        defaults["frequency_hz"] = f"{frequency:g} ({choice.reason}; visited {list(choice.visited_hz)} Hz)"
    result = identify_prd(data, frequency, model, low_force=low, high_forces=highs, estimator=estimator,
                          half_window=half_window)
    f_low, h_low = data.curve(result.setup.low_force)
    h_linear = result.extract_linear_frf(f_low, h_low, amplitude_dependent=args.amplitude_dependent_delta,
                                         smoothing_window=args.smooth_linear)
    real, imag = result.describing_function(max(order, 1))
    prd_real, prd_imag = result.prd_polynomial(max(order, 1))
    delta = result.delta_f1
    summary = {
        "method": "prd",
        "estimator": estimator,
        "excitation_frequency_hz": result.setup.frequency_hz,
        "low_force_n": result.setup.low_force,
        "high_forces_n": list(result.setup.high_forces),
        "describing_function": {
            "real": real, "imag": imag, "amplitude_range_m": list(result.amplitude_range),
            "definition": "high-force DF nu(|X|) in N/m, first-harmonic force = nu*X at the response dof; "
                          "1/H = 1/H_linear + nu; coefficients highest order first (m -> N/m)",
        },
        "prd_fit": {
            "real": prd_real, "imag": prd_imag,
            "definition": "y(|X|) = 1/H_i - 1/H_1 fitted against |X_i| = |H_i| F_i; y(0) = -delta_f1",
        },
        "delta_f1": {"real": delta.real, "imag": delta.imag,
                     "definition": "DF at the low-force amplitude (stuck friction: kf); 1/H_linear = 1/H_1 - delta_f1"},
        "linear_from_level_n": result.setup.low_force,
        "linear_extraction": {"delta_f1": "amplitude dependent" if args.amplitude_dependent_delta else "constant",
                              "smoothing_window_points": args.smooth_linear},
    }
    if choice is not None:
        summary["frequency_choice"] = {"visited_hz": list(choice.visited_hz),
                                       "linear_natural_frequency_hz": choice.linear_natural_frequency_hz,
                                       "reason": choice.reason}
    if result.extras:
        summary["estimator_details"] = dict(result.extras, noise_fraction_from_fit=result.noise_fraction)
    estimate = functools.partial(_prd_estimate, frequency=frequency, model=model, low=result.setup.low_force,
                                 highs=list(result.setup.high_forces), estimator=estimator, half_window=half_window)
    return summary, result, h_linear, f_low, estimate


def _run_ddf(args, data: FRFLevels, physical, order: int, defaults: dict):
    if (args.frequency is not None or args.low_force is not None or args.high_forces is not None
            or args.smooth_linear or args.amplitude_dependent_delta):
        raise CliError("--frequency, --low-force, --high-forces, --smooth-linear and --amplitude-dependent-delta "
                       "apply to --method prd")
    estimator = args.estimator
    if estimator is None:
        estimator = defaults["estimator"] = "naive"
    if estimator not in DDF_ESTIMATORS:
        raise CliError(f"--estimator {estimator!r}: DDF estimators are {', '.join(DDF_ESTIMATORS)}")
    pair = None if args.force_pair is None else tuple(_floats(args.force_pair, "--force-pair", 2))
    band = None if args.band is None else tuple(_floats(args.band, "--band", 2))
    result = identify_ddf(data, pair, band, order, physical=physical, estimator=estimator)
    if pair is None:
        defaults["force_pair_n"] = list(result.setup.force_pair)
    if band is None:
        defaults["band_hz"] = list(result.setup.band_hz)
    f_lin, h_level = data.curve(result.setup.linear_level)
    h_linear = result.extract_linear_frf(f_lin, h_level)
    real, imag = result.describing_function(max(order, 1))
    summary = {
        "method": "ddf",
        "estimator": estimator,
        "excitation_frequency_hz": None,
        "force_pair_n": list(result.setup.force_pair),
        "band_hz": list(result.setup.band_hz),
        "describing_function": {
            "real": real, "imag": imag, "amplitude_range_m": list(result.amplitude_range),
            "definition": "DF Delta(|X|) in N/m (no constant term), first-harmonic force = Delta*X; "
                          "coefficients highest order first (m -> N/m)",
        },
        "linear_from_level_n": result.setup.linear_level,
    }
    estimate = functools.partial(_ddf_estimate, pair=result.setup.force_pair, band=result.setup.band_hz,
                                 order=order, physical=physical, estimator=estimator)
    return summary, result, h_linear, f_lin, estimate
