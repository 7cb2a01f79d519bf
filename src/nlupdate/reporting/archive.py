"""Run archives: one self-describing folder per run.

``<root>/<study>/<UTC time>-<short hash of the inputs>/`` holds::

    manifest.json     study file and its hash, input data hashes, package versions, git
                      commit, seeds, adapter and solver versions, start/end, how the run was
                      orchestrated (flow-run id, tasks computed vs cached), failures and
                      warnings (results not to be trusted as they stand, each
                      {"subject", "kind", "message", "source"}: nlupdate.study.steps.trust.study_warnings,
                      then the validation's and amplitude model's: report.step_warnings)
    study.toml        the study file as run
    inputs/           a copy of every file the study reads (measured data, model files,
                      decks, identification outputs) as ``inputs/<sha256[:12]>/<name>``,
                      listed in the manifest (``inputs.files``: path as written in the
                      study, original path, archived path, SHA-256), so the run can be
                      repeated from the archive alone (:mod:`nlupdate.reporting.catalogue`)
    report.md         the report (:mod:`nlupdate.reporting.report`), plots linked
    identification.json   the identification summary (when the study identifies)
    fe_validation.json    ``[fe_validation]``: the joint identified per bolt, its fit, the shaker's
                      mass, the test's repeatability, the FE points
    amplitude/        ``[amplitude]``: the files ``nlupdate amplitude`` writes for the same
                      sources (amplitude_model.json, backbone.csv, backbone_points.csv,
                      consistency.csv, held_out.csv, backbone.png, damping.png)
    tables/*.parquet  :func:`nlupdate.reporting.tables.study_tables`
    plots/*.png       measured FRFs, DF fit, extracted linear FRF, convergence, candidate
                      errors and FRFs, predictions per level, correlation per level

The folder is written in a temporary sibling and renamed when complete
(:func:`nlupdate.files.atomic_directory`), so a folder under its final name is
always a complete archive.
"""
from __future__ import annotations

import datetime as dt
import hashlib
import os
import re
import stat
import warnings
from pathlib import Path
from typing import Any, Callable, Mapping, Protocol

from matplotlib.figure import Figure

from nlupdate.files import atomic_directory, copy_private, inside, name_problem, write_bytes_atomic
from nlupdate.fingerprints import file_hash, table_hash, tree_hash
from nlupdate.core.identification.trust import POOR_FIT_FACTOR
from nlupdate.core.measurement.units import table_reference_unit
from nlupdate.notices import NlupdateWarning
from nlupdate.reporting.amplitude_report import plot_amplitude_fit
from nlupdate.reporting.figures import frf_curve, png_bytes
from nlupdate.reporting.jsonfile import write_json
from nlupdate.reporting.manifest import environment
from nlupdate.reporting.identification_plots import fit_figure, linear_frf_figure
from nlupdate.reporting.prediction_plots import correlation_figure, measured_frfs_figure, predictions_figure
from nlupdate.reporting.report import report_markdown, step_warnings
from nlupdate.reporting.styles import run_styles
from nlupdate.reporting.tables import study_tables
from nlupdate.reporting.updating_plots import candidate_frfs_figure, convergence_figure, frequency_errors_figure
from nlupdate.reporting.fe_validation_plots import fe_validation_figure
from nlupdate.reporting.validation_plots import held_out_figure, response_controlled_figure, summary_figure

MANIFEST = "manifest.json"
#: The kind of output folder an archive is (:func:`nlupdate.files.check_replaceable`).
ARCHIVE_KIND = "archive"


def measured_fingerprint(result) -> dict[str, str] | None:
    """Where the measured data came from and the SHA-256 of their content (and file)."""
    if result.measured is None:
        return None
    spec = result.study.measured
    source = spec.file or ", ".join([p for p, _ in spec.files] or list(spec.time_histories)) or \
        "simulated ([measured.simulate])"
    out = {"source": source,
           "sha256": table_hash(result.measured)}
    if spec.file is not None:
        out["file_sha256"] = file_hash(spec.file)
    return out


def inputs_hash(result) -> str:
    """Hash of what determines the run's results: the study text and the measured data."""
    digest = hashlib.sha256(result.study.text.encode())
    measured = measured_fingerprint(result)
    if measured is not None:
        digest.update(measured["sha256"].encode())
    return digest.hexdigest()


def archive_inputs(study, folder: Path) -> list[dict[str, str]]:
    """Copy every file (or folder) ``study`` reads into ``folder/inputs``; returns their
    manifest entries (see the module docstring). Copies are never more readable than
    their originals; links in an input folder are followed only when they point inside
    it, others are kept as links (and said so in one line)."""
    entries = []
    for written, source in sorted(study.input_files.items()):
        source = Path(source)
        digest = tree_hash(source) if source.is_dir() else file_hash(source)
        archived = Path("inputs") / digest[:12] / source.name
        target = folder / archived
        if not target.exists():
            target.parent.mkdir(parents=True, exist_ok=True)
            if source.is_dir():
                copy_input_folder(source, target)
            else:
                copy_private(source, target)
        entries.append({"as_written": written, "source": str(source.resolve()), "archived": archived.as_posix(),
                        "sha256": digest})
    return entries


def copy_input_folder(source: Path, target: Path, top: Path | None = None) -> None:
    """Copy the input folder ``source`` to ``target``: files with permissions no wider than
    theirs; a link that resolves inside ``source`` is followed, any other (pointing outside,
    or to nothing) is archived as the link it is and reported in one line — its target is
    not read. ``top``: the input folder a subfolder ``source`` belongs to."""
    top = (top or source).resolve()
    target.mkdir(mode=0o700)
    for entry in sorted(source.iterdir()):
        copy = target / entry.name
        if entry.is_symlink():
            pointee = entry.resolve()
            within = pointee.exists() and (pointee == top or top in pointee.parents)
            if within and pointee.is_file():
                copy_private(pointee, copy)
                continue
            if not within:
                reason = "points to nothing" if not pointee.exists() else "points outside the input folder"
                warnings.warn(f"input folder {top}: {entry} is a link that {reason} ({os.readlink(entry)}); "
                              f"archived as a link, its target not copied", NlupdateWarning, stacklevel=2)
            os.symlink(os.readlink(entry), copy)
        elif entry.is_dir():
            copy_input_folder(entry, copy, top)
        elif entry.is_file():
            copy_private(entry, copy)
    os.chmod(target, stat.S_IMODE(source.stat().st_mode) & 0o777)


def study_record(study) -> dict[str, str]:
    """Name, file (absolute; or a note when the text did not come from a file, as for the
    demo's embedded study), SHA-256 of the text and description of ``study``."""
    path = Path(study.path)
    file = str(path.resolve()) if path.is_file() else f"{path} (embedded: the text is in study.toml)"
    return {"name": study.name, "file": file, "sha256": study.sha256, "description": study.description}


def run_folder(root: str | Path, study_name: str, started: dt.datetime, digest: str) -> Path:
    """``<root>/<study>/<UTC time>-<8 hex digits of the inputs hash>``, checked to be inside
    ``root`` (a study name is one folder name, :func:`nlupdate.files.name_problem`)."""
    problem = name_problem(study_name)
    if problem is not None:
        raise ValueError(f"study name {study_name!r} is {problem}; it cannot name a folder under {root}")
    folder = Path(root) / study_name / f"{started.astimezone(dt.timezone.utc):%Y%m%dT%H%M%SZ}-{digest[:8]}"
    return inside(root, folder)


def build_manifest(result, run_id: str, run: Mapping[str, Any], tables: list[str], plots: Mapping[str, str],
                   inputs: list[dict[str, str]]) -> dict:
    """The manifest of a run (see the module docstring); ``run`` describes how it ran,
    ``inputs`` the archived input files (:func:`archive_inputs`)."""
    study = result.study
    seeds = {}
    if study.measured is not None and study.measured.simulate is not None:
        seeds["simulated_noise"] = study.measured.simulate.seed
    if study.identification is not None:
        seeds["monte_carlo"] = study.identification.seed
    return {
        "run_id": run_id,
        "status": "failed" if result.failures else "complete",
        "study": study_record(study),
        "inputs": {"measured": measured_fingerprint(result), "inputs_sha256": inputs_hash(result), "files": inputs},
        "seeds": seeds,
        "adapters": dict(result.models),
        "environment": environment(),
        "run": dict(run),
        "failures": [{"run": f.name, "error": f.error} for f in result.failures],
        "warnings": [w.as_dict() for w in result.warnings] + step_warnings(result),
        "tables": tables,
        "plots": dict(plots),
    }


def target_sigma_pct(result) -> dict[str, float]:
    """Each target's standard deviation in % of its frequency, by label (empty without)."""
    if result.targets is None or result.targets.std_hz is None:
        return {}
    t = result.targets.targets
    return {label: 100.0 * float(std) / float(f) for label, std, f in zip(t.labels, result.targets.std_hz, t.frequencies_hz)}


def archive_figures(result) -> list[tuple[str, str, Callable[[], Figure]]]:
    """(key, file name, function drawing the Figure) of every plot ``result`` supports, in
    the order of the report."""
    study = result.study
    plots: list[tuple[str, str, Callable[[], Figure]]] = []
    ident = result.identification
    pair = None
    if ident is not None:
        pair = (ident.settings.response_dof, ident.settings.input_dof)
    elif result.measured is not None:
        first = result.measured.iloc[0]
        pair = (str(first["response_dof"]), str(first["input_dof"]))
    if result.measured is not None:
        plots.append(("measured", "measured_frfs.png",
                      lambda: measured_frfs_figure(result.measured, *pair, f"measured receptance {pair[0]}/{pair[1]}")))
    if ident is not None:
        title = f"{ident.settings.method.upper()} ({ident.result.estimator}), {pair[0]}/{pair[1]}"
        plots.append(("fit", "identification_fit.png", lambda: fit_figure(ident, title, POOR_FIT_FACTOR)))
        source = None
        if result.measured is not None:
            level = ident.linear_from_level_n
            source = (f"{level:g} {ident.reference_unit}", *frf_curve(result.measured, *pair, level))
        plots.append(("linear_frf", "linear_frf.png",
                      lambda: linear_frf_figure(ident, source, f"extracted linear FRF ({title})")))
    if result.runs:
        styles = run_styles(result.runs)
        sigma = target_sigma_pct(result)
        plots.append(("convergence", "convergence.png",
                      lambda: convergence_figure(study_tables(result)["histories"], styles, study.parameters,
                                                 study.hidden_truth, sigma)))
        plots.append(("frequency_errors", "frequency_errors.png",
                      lambda: frequency_errors_figure(result.comparison, styles, sigma)))
        frfs = result.candidate_frfs
        if frfs is not None:
            reference = "linear FRF of [comparison] frf" if study.comparison.frf is not None else \
                "extracted linear FRF"
            plots.append(("frf_comparison", "candidate_frfs.png",
                          lambda: candidate_frfs_figure(frfs, styles, f"{study.name}: linear FRF of each candidate "
                                                                      f"model against the {reference}", reference)))
    if result.predictions:
        plots.append(("predictions", "prediction_vs_measurement.png",
                      lambda: predictions_figure(result.measured, result.predictions, *pair,
                                                 f"{study.name}: initial and updated nonlinear models vs measurement")))
        plots.append(("correlation", "correlation_per_level.png",
                      lambda: correlation_figure(study_tables(result)["correlation"],
                                                 table_reference_unit(result.measured))))
    validation = result.validation
    if validation is not None:
        plots.append(("validation", "validation.png", lambda: summary_figure(validation)))
        if validation.response_controlled:
            plots.append(("response_controlled", "response_controlled.png",
                          lambda: response_controlled_figure(validation)))
        for held in validation.held_out:
            name = f"held_out_{held.level:g}_{held.requested}".replace(".", "p")
            plots.append((name, f"{re.sub(r'[^A-Za-z0-9_]+', '-', name)}.png",
                          lambda held=held: held_out_figure(held, validation.reference_unit)))
    if result.fe_validation is not None:
        plots.append(("fe_validation", "fe_validation.png", lambda: fe_validation_figure(result.fe_validation)))
    return plots


def _plots(result, folder: Path, figures: FigureKeeper | None = None) -> dict[str, str]:
    """Write every plot of :func:`archive_figures` into ``folder`` — as ``figures`` kept it
    from an earlier run of the same results, else drawn (and given to ``figures`` to keep);
    returns key → file name."""
    written: dict[str, str] = {}
    for key, name, draw in archive_figures(result):
        png = figures.get(name) if figures is not None else None
        if png is None:
            png = png_bytes(draw(), dpi=110 if key == "predictions" else 120)
            if figures is not None:
                figures.put(name, png)
        write_bytes_atomic(folder / name, png)
        written[key] = f"plots/{name}"
    return written


def write_amplitude(fit, folder: Path) -> dict[str, str]:
    """``[amplitude]``'s files in ``folder`` (``amplitude/`` of the archive), as ``nlupdate
    amplitude`` writes them: the model, backbone.csv, backbone_points.csv, consistency.csv,
    held_out.csv and the two figures; returns the figures' keys → paths in the archive."""
    folder.mkdir()
    fit.write(folder)
    plot_amplitude_fit(fit, folder)
    return {"amplitude_backbone": f"{folder.name}/backbone.png", "amplitude_damping": f"{folder.name}/damping.png"}


class FigureKeeper(Protocol):
    """Where an archive's figures are kept between runs of the same results (the flows
    give :class:`nlupdate.orchestration.tasks.figures.FigureStore`): PNG bytes by file name."""

    def get(self, name: str) -> bytes | None: ...

    def put(self, name: str, png: bytes) -> None: ...


def write_archive(result, final: str | Path, run: Mapping[str, Any], on_exists: str = "suffix",
                  figures: FigureKeeper | None = None) -> Path:
    """Write the archive of ``result`` to ``final`` (atomically); returns the folder.

    ``run``: how the run went (``started_utc``, ``finished_utc``, ``wall_time_s`` — the wall time
    of its steps, from the first to the last: not starting the Prefect server, not writing this
    archive —, ``orchestration``, flow-run id, tasks computed vs cached, …) for the manifest.
    ``on_exists`` as for :func:`~nlupdate.files.atomic_directory`; ``figures``: the figures
    an earlier run of the same results drew (:class:`FigureKeeper`), else every one is drawn.
    """
    final = Path(final)
    with atomic_directory(final, on_exists=on_exists, kind=ARCHIVE_KIND) as archive:
        folder = archive.path
        (folder / "tables").mkdir()
        (folder / "plots").mkdir()
        tables = study_tables(result)
        for name, table in tables.items():
            table.to_parquet(folder / "tables" / f"{name}.parquet", index=False)
        plots = _plots(result, folder / "plots", figures)
        (folder / "study.toml").write_text(result.study.text)
        inputs = archive_inputs(result.study, folder)
        if result.identification is not None:
            write_json(result.identification.summary(), folder / "identification.json")
        if result.validation is not None:
            write_json(result.validation.summary(), folder / "validation.json")
        if result.fe_validation is not None:
            write_json(result.fe_validation.summary(), folder / "fe_validation.json")
        if result.amplitude is not None:
            plots.update(write_amplitude(result.amplitude, folder / "amplitude"))
        manifest = build_manifest(result, final.name, run, sorted(tables), plots, inputs)
        write_json(manifest, folder / MANIFEST)
        (folder / "report.md").write_text(report_markdown(result, manifest, plots))
    return archive.final


def write_failed_archive(study, final: str | Path, run: Mapping[str, Any], error: str) -> Path:
    """The archive of a study that failed with ``error`` before it had results: the
    manifest (status ``failed``, the error, versions), the study file, its inputs and a
    short report. Written atomically like :func:`write_archive`; returns the folder."""
    final = Path(final)
    with atomic_directory(final, kind=ARCHIVE_KIND) as archive:
        folder = archive.path
        (folder / "study.toml").write_text(study.text)
        inputs = archive_inputs(study, folder)
        manifest = {
            "run_id": final.name, "status": "failed", "error": error,
            "study": study_record(study),
            "inputs": {"files": inputs}, "environment": environment(), "run": dict(run), "failures": [], "warnings": [],
        }
        write_json(manifest, folder / MANIFEST)
        (folder / "report.md").write_text(f"# {study.name}: failed\n\n## Summary\n\n**The study failed**: {error}\n\n"
                                          f"Nothing after the failing step was computed; steps finished before it "
                                          f"stay in the task cache ({run.get('cache_store')}).\n")
    return archive.final
