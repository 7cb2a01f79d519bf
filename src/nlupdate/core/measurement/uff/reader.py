"""Reading measured FRFs from a UFF file: walking its datasets 58 into one raw FRF table.

Datasets other than 58 are skipped, and so are 58 datasets of spectra and time records
(function types 1, 2, 3, 8, 9 …, with a warning naming them). Each FRF (function type 4) is
decoded by :mod:`~nlupdate.core.measurement.uff.fields` and its level found by
:mod:`~nlupdate.core.measurement.uff.levels`. Transmissibility (function type 5) is refused.

* **Runs**: a file may hold several runs (one per level); a dataset's run name comes
  from its ID lines (:func:`nlupdate.core.measurement.run_levels.run_names`).
* **Coherence**: datasets of function type 6 (coherence) are attached to the FRF of the
  same response, reference and level as the column ``coherence``.
* A last dataset without its end delimiter (a truncated file) is refused.
"""
from __future__ import annotations

import tempfile
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pyuff

from nlupdate.core.measurement.frf_table import MeasurementTableError, validate_frf_table
from nlupdate.core.measurement.run_levels import run_names
from nlupdate.core.measurement.uff.codes import (
    COHERENCE, FRF, FUNCTION_NAMES, TIME_RESPONSE, TRANSMISSIBILITY, check_directions, id_lines,
)
from nlupdate.core.measurement.uff.fields import (
    check_count, read_abscissa_hz, read_coordinates, read_excitation, read_ordinate, read_reference,
)
from nlupdate.core.measurement.uff.levels import dataset_level
from nlupdate.core.measurement.units import RESPONSE_QUANTITY, ReadOptions, table_reference_unit
from nlupdate.notices import NlupdateWarning


def _frf_curve(dataset: dict, where: str, options: ReadOptions, given_level: float | None, runs: str,
               contradictions: list) -> pd.DataFrame:
    """One FRF dataset as a raw table curve in receptance (m per reference unit)."""
    check_directions(dataset, where)
    if dataset.get("ord_data_type") not in (5, 6):
        raise MeasurementTableError(f"{where}: ordinate data type {dataset.get('ord_data_type')} is real; an FRF needs "
                                    f"complex data (5 or 6)")
    check_count(dataset, where)
    frequency = read_abscissa_hz(dataset, where)
    power, to_si = read_ordinate(dataset, where)
    unit, per_unit = read_reference(dataset, where, options.reference_unit)
    level = dataset_level(dataset, where, unit, given_level, runs, contradictions)
    response, inp, sign = read_coordinates(dataset)
    h = np.asarray(dataset["data"], dtype=complex) * (sign * to_si * per_unit)
    if power:
        dc = frequency <= 0
        if dc.any():
            frequency, h = frequency[~dc], h[~dc]
            warnings.warn(f"{where}: dropped the 0 Hz line: {RESPONSE_QUANTITY[power]} cannot be converted to receptance "
                          f"at 0 Hz", NlupdateWarning, stacklevel=5)
        h = h / (1j * 2 * np.pi * frequency) ** power
        name = {1: "mobility (velocity/force)", 2: "accelerance (acceleration/force)"}[power]
        warnings.warn(f"{where}: converted {name} to receptance: H = {'A' if power == 2 else 'V'}/(iω)"
                      f"{'²' if power == 2 else ''}", NlupdateWarning, stacklevel=5)
    curve = pd.DataFrame({
        "frequency_hz": frequency, "force_level_n": level, "response_dof": response, "input_dof": inp,
        "h_real": h.real, "h_imag": h.imag,
    })
    excitation = read_excitation(dataset)
    if excitation != "unknown":
        curve["excitation"] = excitation
    if unit == "V":
        curve["reference_unit"] = "V"
    return curve


def _coherence_curve(dataset: dict, where: str, options: ReadOptions, given_level: float | None, unit: str):
    """(response, input, level or None, frequencies, coherence) of a coherence dataset."""
    check_directions(dataset, where)
    check_count(dataset, where)
    frequency = read_abscissa_hz(dataset, where)
    values = np.real(np.asarray(dataset["data"]))
    response, inp, _ = read_coordinates(dataset)
    try:
        level = dataset_level(dataset, where, unit, given_level, "")
    except MeasurementTableError:
        level = None
    return response, inp, level, frequency, values


def _check_complete(data: bytes, uff: pyuff.UFF, source: str) -> None:
    """Refuse a file whose last dataset has no end delimiter (a truncated file).

    pyuff indexes only complete datasets (between ``-1`` delimiter lines) and would
    silently drop a cut-off last one.
    """
    blocks = getattr(uff, "_block_ind", None)
    end = int(blocks[-1][1]) + 1 if blocks is not None and len(blocks) else 0  # [first, last] byte
    rest = data[end:].replace(b"-1", b"", 1).strip() if end else data.strip()
    if end and rest or not end and data.strip():
        count = len(blocks) if blocks is not None else 0
        raise MeasurementTableError(
            f"{source}: incomplete record: dataset {count} (from byte {end}) has no end delimiter '-1'; the file "
            f"is truncated or not a complete UFF file ({len(data)} bytes)")


def uff_datasets(data: bytes, source: str | Path) -> tuple[list[int], list[dict]]:
    """(indices, contents) of the datasets 58 in the UFF bytes ``data`` (pyuff reads a
    private temporary copy, so what is parsed is exactly what was read)."""
    with tempfile.TemporaryDirectory(prefix="nlupdate-uff-") as folder:
        copy = Path(folder) / "data.uff"
        copy.write_bytes(data)
        try:
            uff = pyuff.UFF(str(copy))
            indices = [i for i, t in enumerate(uff.get_set_types()) if t == 58]
            datasets = [uff.read_sets(i) for i in indices]
        except Exception as error:  # pyuff raises bare Exception on malformed files
            raise MeasurementTableError(f"{source}: not a readable UFF file ({error})") from None
    _check_complete(data, uff, str(source))
    return indices, datasets


def read_uff_frf(data: bytes, path: Path, options: ReadOptions) -> pd.DataFrame:
    """The FRFs (and their coherences) of a UFF file's bytes as a raw table (package docstring)."""
    indices, datasets = uff_datasets(data, path)
    if not datasets:
        raise MeasurementTableError(f"{path}: no dataset 58 (function at nodal DOF) found")
    runs = run_names([id_lines(d) for d in datasets], [(d.get("func_type"), *read_coordinates(d)[:2]) for d in datasets])
    distinct_runs = list(dict.fromkeys(r for r, d in zip(runs, datasets) if d.get("func_type") == FRF))
    several = len(distinct_runs) > 1
    listing = f"; the file's runs: {', '.join(repr(r) for r in distinct_runs)} — give a run's level with --level " \
              f"{Path(path).name}#RUN=VALUE" if several else ""
    file_level = options.level_of(str(path))
    if file_level is not None and several:
        raise MeasurementTableError(
            f"{path}: holds {len(distinct_runs)} runs ({', '.join(repr(r) for r in distinct_runs)}); a level given for "
            f"the file ({file_level:g}) fits a file of one run: give each run's level with --level "
            f"{Path(path).name}#RUN=VALUE (study: [measured] levels = {{\"{Path(path).name}#RUN\" = VALUE}})")
    curves, seen, coherences, skipped, contradictions = [], {}, [], {}, {}
    for index, dataset, run in zip(indices, datasets, runs):
        where = f"{path}, dataset {index}" + (f" (run {run!r})" if several else "")
        given = options.level_of_run(str(path), run) if run else None
        if given is not None and file_level is not None and given != file_level:
            raise MeasurementTableError(
                f"{path}: levels given for the file ({file_level:g}) and for its run {run!r} ({given:g}) contradict "
                f"each other (--level, study [measured] levels); expected one level")
        given = file_level if given is None else given
        function = dataset.get("func_type")
        if function == FRF:
            found: list = []
            curve = validate_frf_table(_frf_curve(dataset, where, options, given, listing, found), source=where)
            if found:
                contradictions.setdefault((run, found[0][1]), set()).add(found[0][0])
            key = tuple(curve.loc[0, ["force_level_n", "response_dof", "input_dof"]]) if len(curve) else None
            if key in seen:
                raise MeasurementTableError(
                    f"{path}: datasets {seen[key]} and {index} hold the same curve (level, response_dof, input_dof) = "
                    f"{key}{listing or ''}")
            seen[key] = index
            curves.append(curve)
        elif function == COHERENCE:
            coherences.append((index, _coherence_curve(dataset, where, options, given, options.reference_unit or "N")))
        elif function == TRANSMISSIBILITY:
            raise MeasurementTableError(f"{where}: function type 5 (transmissibility); expected 4 (frequency response "
                                        f"function) or 6 (coherence)")
        else:
            skipped.setdefault(function, []).append(index)
    if not curves:
        kinds = ", ".join(f"{len(v)} × type {k} ({FUNCTION_NAMES.get(k, 'other')})" for k, v in skipped.items())
        hint = " — time records become FRFs with 'nlupdate frf'" if TIME_RESPONSE in skipped else ""
        raise MeasurementTableError(f"{path}: no frequency response function (dataset 58, function type 4); found "
                                    f"{kinds}{hint}")
    if skipped:
        kinds = ", ".join(f"{FUNCTION_NAMES.get(k, f'type {k}')} (datasets {v})" for k, v in skipped.items())
        warnings.warn(f"{path}: skipped datasets that are no FRF: {kinds}", NlupdateWarning, stacklevel=4)
    for index, (response, inp, level, frequency, values) in coherences:
        _attach_coherence(curves, f"{path}, dataset {index}", response, inp, level, frequency, values)
    if len({table_reference_unit(c) for c in curves}) > 1:
        raise MeasurementTableError(f"{path}: the datasets mix force (N) and voltage (V) references")
    unit = table_reference_unit(curves[0])
    for (run, typed), values in contradictions.items():
        levels = ", ".join(f"{v:g}" for v in sorted(values))
        warnings.warn(f"{path}{f' run {run!r}' if run else ''}: the z-axis level {levels} is {typed}, while the "
                      f"reference is {unit}; used as {levels} {unit} (state another with --level "
                      f"{Path(path).name}{f'#{run}' if run else ''}=VALUE)", NlupdateWarning, stacklevel=4)
    for column, missing in (("coherence", np.nan), ("excitation", "unknown")):
        if any(column in c.columns for c in curves):
            for curve in curves:
                if column not in curve.columns:
                    curve[column] = missing
    table = pd.concat(curves, ignore_index=True)
    if "coherence" in table.columns and table["coherence"].isna().any():
        missing = table.loc[table["coherence"].isna(), ["response_dof", "input_dof", "force_level_n"]].iloc[0]
        warnings.warn(f"{path}: no coherence for response {missing['response_dof']!r}, input {missing['input_dof']!r}, "
                      f"level {missing['force_level_n']:g}: the coherence column is left out", NlupdateWarning,
                      stacklevel=4)
        table = table.drop(columns="coherence")
    table.attrs["runs"] = tuple(r for r in distinct_runs if r)  # the run names, for --level FILE#RUN / RUN
    return table


def _attach_coherence(curves: list[pd.DataFrame], where: str, response: str, inp: str, level: float | None,
                      frequency: np.ndarray, values: np.ndarray) -> None:
    """Add the coherence ``values`` as the column ``coherence`` of the one FRF curve it belongs to."""
    matches = [c for c in curves if c["response_dof"].iloc[0] == response and c["input_dof"].iloc[0] == inp
               and (level is None or np.isclose(c["force_level_n"].iloc[0], level, rtol=1e-9))]
    if len(matches) != 1:
        raise MeasurementTableError(
            f"{where}: coherence of response {response!r}, input {inp!r}"
            f"{'' if level is None else f', level {level:g}'} fits {len(matches)} FRF curves; it must fit exactly one "
            f"(same coordinates and level)")
    curve = matches[0]
    f = curve["frequency_hz"].to_numpy()
    position = np.clip(np.searchsorted(frequency, f), 0, frequency.size - 1)
    hit = np.isclose(frequency[position], f, rtol=1e-9, atol=1e-9)
    before = np.clip(position - 1, 0, frequency.size - 1)
    hit_before = np.isclose(frequency[before], f, rtol=1e-9, atol=1e-9)
    index = np.where(hit, position, before)
    if not np.all(hit | hit_before):
        missing = f[~(hit | hit_before)][0]
        raise MeasurementTableError(f"{where}: the coherence has no value at {missing:g} Hz, where its FRF has one")
    coherence = values[index]
    if np.any(~np.isfinite(coherence)) or np.any(coherence < -1e-9) or np.any(coherence > 1 + 1e-9):
        raise MeasurementTableError(f"{where}: coherence values outside 0…1 (min {np.min(coherence):.3g}, max "
                                    f"{np.max(coherence):.3g})")
    curve["coherence"] = np.clip(coherence, 0.0, 1.0)


