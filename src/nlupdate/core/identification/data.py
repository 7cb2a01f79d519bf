"""Measured FRF curves of one (response, input) pair at several force levels.

:class:`FRFLevels` is the input of the PRD and DDF methods: one receptance curve
(frequencies in Hz ascending, complex H in m/N) per force amplitude (N), taken from a
measured-FRF table (:mod:`nlupdate.core.measurement.frf_table`). Frequencies are matched exactly
(relative 1e-9), as a stepped-sine test repeats the same frequencies at every level.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.measurement.band import in_band
from nlupdate.core.measurement.frf_table import force_levels, select_frf
from nlupdate.core.measurement.noise import add_frf_noise

_RTOL = 1e-9

#: A level measured at fewer lines than this is a single- (or few-) frequency level, not a
#: sweep. The source's own PRD experiment (docs/methods.md §4) measures its high forces so:
#: one pure sine near resonance per level. The band and the coherence threshold choose the
#: lines of a sweep; a single-frequency level keeps its lines (it has no others to choose
#: from), and each method names the levels it needs as sweeps.
MIN_SWEEP_LINES = 3


def match_frequencies(available: NDArray, wanted: NDArray) -> NDArray[np.int64]:
    """Index into ``available`` of each ``wanted`` frequency, −1 where absent."""
    position = np.clip(np.searchsorted(available, wanted), 0, max(available.size - 1, 0))
    out = np.full(wanted.shape, -1, dtype=np.int64)
    for offset in (0, -1):
        candidate = np.clip(position + offset, 0, available.size - 1)
        hit = np.isclose(available[candidate], wanted, rtol=_RTOL, atol=1e-12) & (out < 0)
        out[hit] = candidate[hit]
    return out


class LinearLimitLike(Protocol):
    """A mode's linear limit from another test: natural frequency (Hz), damping ratio, their
    standard errors and where it came from (:class:`~nlupdate.core.identification.impact.LinearLimit`
    is one; a protocol, so that this module need not import the impact fit)."""

    frequency_hz: float
    damping_ratio: float
    frequency_std_hz: float
    damping_std: float
    source: str


@dataclass(frozen=True, eq=False)
class FRFLevels:
    """Receptance curves of one coordinate pair, one per force level (ascending).

    coherences: per level the ordinary coherence at each frequency (None when the table
    has none); reference_unit: ``"N"`` or ``"V"`` (levels in V and H in m/V);
    excitation: how the FRFs were measured (``stepped_sine``, ``chirp``, ``random`` …,
    ``unknown``); averages: per level the number of averages at each frequency (None
    when unknown); achieved: per level the force amplitude achieved at each frequency
    (the table's ``level_achieved``; None when the table has none, and then every line
    of a level was measured at the level itself). A controller that does not hold the
    force through a resonance leaves it lower there than the level: the response
    amplitude of a line is ``|H|·achieved``, not ``|H|·level`` (:meth:`force_at`).
    linear_limit: the mode's linear limit measured by another test of the structure (an
    impact's pole, :class:`LinearLimitLike`), kept with
    the curves as evidence a model may fit beside them (None: none); every subset keeps it.
    """

    response_dof: str
    input_dof: str
    levels: NDArray[np.float64]
    frequencies: tuple[NDArray[np.float64], ...]
    receptances: tuple[NDArray[np.complex128], ...]
    coherences: tuple[NDArray[np.float64], ...] | None = None
    reference_unit: str = "N"
    excitation: str = "unknown"
    averages: tuple[NDArray[np.float64], ...] | None = None
    h_stds: tuple[NDArray[np.float64], ...] | None = None
    achieved: tuple[NDArray[np.float64], ...] | None = None
    linear_limit: LinearLimitLike | None = None

    @classmethod
    def from_table(cls, table: pd.DataFrame, response_dof: str, input_dof: str) -> "FRFLevels":
        """All force levels of ``response_dof``/``input_dof``; unknown dofs raise ValueError,
        and so does a receptance of exactly 0 (it has no inverse)."""
        response, inp = str(response_dof), str(input_dof)
        if table.empty:
            raise ValueError("the measured table holds no measurement (no rows)")
        for column, name in (("response_dof", response), ("input_dof", inp)):
            names = sorted(set(table[column].astype(str)))
            if name not in names:
                raise ValueError(f"unknown {column} {name!r}: the measured table has {column} {names}")
        pair = table[(table["response_dof"].astype(str) == response) & (table["input_dof"].astype(str) == inp)]
        if pair.empty:
            raise ValueError(f"no measured FRF with response_dof={response!r} and input_dof={inp!r}")
        levels = force_levels(pair)
        curves = [select_frf(pair, response, inp, level) for level in levels]
        for level, (f, h) in zip(levels, curves):
            if np.any(h == 0):
                raise ValueError(f"H = 0 at {f[np.flatnonzero(h == 0)[0]]:g} Hz, level {level:g}: a receptance of "
                                 f"0 has no inverse (no response was measured there)")

        def column(name: str) -> tuple[NDArray[np.float64], ...] | None:
            if name not in pair.columns:
                return None
            out = []
            for level in levels:
                rows = pair[np.isclose(pair["force_level_n"].to_numpy(float), level, rtol=_RTOL, atol=0.0)]
                rows = rows.sort_values("frequency_hz", kind="mergesort")
                out.append(rows[name].to_numpy(dtype=float))
            return tuple(out)

        excitation = sorted(set(pair["excitation"])) if "excitation" in pair.columns else ["unknown"]
        unit = str(pair["reference_unit"].iloc[0]) if "reference_unit" in pair.columns else "N"
        return cls(response, inp, levels, tuple(c[0] for c in curves), tuple(c[1] for c in curves),
                   column("coherence"), unit, "+".join(excitation), column("averages"), column("h_std"),
                   column("level_achieved"))

    def sweep_levels(self) -> tuple[float, ...]:
        """The levels measured as sweeps (at least :data:`MIN_SWEEP_LINES` lines)."""
        return tuple(float(level) for level, f in zip(self.levels, self.frequencies) if f.size >= MIN_SWEEP_LINES)

    def _masked(self, keep: list[NDArray[np.bool_]]) -> "FRFLevels":
        """The sweeps' lines where ``keep``; a single-frequency level keeps its lines (it has
        no others to choose from: :data:`MIN_SWEEP_LINES`)."""
        keep = [k | (f.size < MIN_SWEEP_LINES) for k, f in zip(keep, self.frequencies)]

        def pick(arrays):
            return None if arrays is None else tuple(a[k] for a, k in zip(arrays, keep))

        return dataclasses.replace(self, frequencies=pick(self.frequencies), receptances=pick(self.receptances),
                                   coherences=pick(self.coherences), averages=pick(self.averages),
                                   h_stds=pick(self.h_stds), achieved=pick(self.achieved))

    def within(self, band_hz: tuple[float, float]) -> "FRFLevels":
        """The sweeps restricted to ``band_hz`` = (low, high) Hz, ends included."""
        return self._masked([in_band(f, band_hz) for f in self.frequencies])

    def coherent(self, threshold: float) -> "FRFLevels":
        """The sweeps without the lines whose coherence is below ``threshold`` (unchanged
        without coherence)."""
        if self.coherences is None:
            return self
        return self._masked([c >= threshold for c in self.coherences])

    def level_index(self, force_n: float) -> int:
        hit = np.flatnonzero(np.isclose(self.levels, float(force_n), rtol=_RTOL, atol=0.0))
        if hit.size == 0:
            raise ValueError(
                f"force level {float(force_n):g} N not measured for response {self.response_dof!r} / input "
                f"{self.input_dof!r}; levels: {[float(f) for f in self.levels]} N"
            )
        return int(hit[0])

    def curve(self, force_n: float) -> tuple[NDArray[np.float64], NDArray[np.complex128]]:
        k = self.level_index(force_n)
        return self.frequencies[k], self.receptances[k]

    def common_frequencies(self, levels: ArrayLike) -> NDArray[np.float64]:
        """Frequencies (Hz) measured at every one of ``levels``."""
        indices = [self.level_index(level) for level in np.atleast_1d(levels)]
        common = self.frequencies[indices[0]]
        for k in indices[1:]:
            common = common[match_frequencies(self.frequencies[k], common) >= 0]
        return common

    def values(self, force_n: float, frequency_hz: ArrayLike) -> NDArray[np.complex128]:
        """H at given frequencies of one level; ValueError naming a missing frequency."""
        f, h = self.curve(force_n)
        wanted = np.atleast_1d(np.asarray(frequency_hz, dtype=float))
        index = match_frequencies(f, wanted)
        if np.any(index < 0):
            missing = wanted[index < 0][0]
            raise ValueError(
                f"frequency {missing:g} Hz not measured at {float(force_n):g} N (response "
                f"{self.response_dof!r}, input {self.input_dof!r}); measured {f.min():g}–{f.max():g} Hz, "
                f"{f.size} points"
            )
        return h[index]

    def force_at(self, force_n: float, frequency_hz: ArrayLike) -> NDArray[np.float64]:
        """Force amplitude (reference unit) at which the level ``force_n`` was measured at
        each of ``frequency_hz``: the achieved force, linearly interpolated between the
        measured lines (held at the ends), or the level itself when none is recorded."""
        wanted = np.asarray(frequency_hz, dtype=float)
        k = self.level_index(force_n)
        if self.achieved is None:
            return np.full(wanted.shape, float(self.levels[k]))
        return np.interp(wanted, self.frequencies[k], self.achieved[k])

    def has_frequency(self, force_n: float, frequency_hz: float) -> bool:
        f, _ = self.curve(force_n)
        return bool(match_frequencies(f, np.array([float(frequency_hz)]))[0] >= 0)

    def subset(self, levels: ArrayLike) -> "FRFLevels":
        indices = [self.level_index(level) for level in np.atleast_1d(levels)]
        def pick(arrays):
            return None if arrays is None else tuple(arrays[k] for k in indices)

        return dataclasses.replace(self, levels=self.levels[indices], frequencies=pick(self.frequencies),
                                   receptances=pick(self.receptances), coherences=pick(self.coherences),
                                   averages=pick(self.averages), h_stds=pick(self.h_stds),
                                   achieved=pick(self.achieved))

    def with_noise(self, fraction: float, rng: np.random.Generator) -> "FRFLevels":
        """A copy with docs/methods.md §8 noise (std = fraction·|H|) added to every value."""
        return dataclasses.replace(self, receptances=tuple(add_frf_noise(h, fraction, rng) for h in self.receptances))
