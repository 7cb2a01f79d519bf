"""The one interface every FE code sits behind.

An adapter maps a named parameter vector to a :class:`ModalResult`: natural
frequencies (Hz), mass-normalised mode shapes at named measurement coordinates, and
metadata (solver, mesh size, wall time, log path). Linear receptances at those
coordinates follow by modal superposition (:meth:`ModalResult.to_modal_model`).

An adapter only solves: it holds no cache and no worker pool, so one instance can be
used from several threads or shipped to a worker process. :meth:`FEAdapter.key` names a
point by a hash of (adapter name, model fingerprint, parameter values); whoever runs
the evaluations uses that key to compute each point once — the in-run memo of
:class:`nlupdate.core.updating.evaluation.MemoisedEvaluator`, or the persistent task cache of
the Prefect flows (:mod:`nlupdate.orchestration.tasks`). Subclasses implement only
:meth:`FEAdapter.model_fingerprint` and :meth:`FEAdapter._solve`.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from nlupdate.fingerprints import fingerprint
from nlupdate.core.model.linear import ModalModel


@dataclass(frozen=True)
class Parameter:
    """An updating parameter.

    ``relative_step`` is the finite-difference step as a fraction of the current value
    (h = relative_step·|p|, or relative_step·(upper − lower) when p = 0). ``unit`` and
    ``description`` (what the parameter is, in a few words: "thickness of the two thin
    beams") are labels: progress lines and reports name the parameter with them.
    """

    name: str
    unit: str
    start: float
    lower: float
    upper: float
    relative_step: float = 1e-3
    description: str = ""

    def __post_init__(self) -> None:
        if not (self.lower <= self.start <= self.upper):
            raise ValueError(
                f"parameter {self.name!r}: start {self.start} {self.unit} is outside its bounds "
                f"[{self.lower}, {self.upper}]"
            )
        if not (0 < self.relative_step < 1):
            raise ValueError(f"parameter {self.name!r}: relative_step must be in (0, 1), got {self.relative_step}")

    def described(self) -> str:
        """The name with what it is and its unit, as a reader first meets it:
        ``h2 (thickness of the two thin beams, m)``; ``k1 (N/m)`` without a description."""
        said = ", ".join(part for part in (self.description, "" if self.unit in ("1", "-") else self.unit) if part)
        return f"{self.name} ({said})" if said else self.name


@dataclass(frozen=True, eq=False)
class ModalResult:
    """Outcome of one FE evaluation.

    natural_frequencies_hz: shape (n_modes,), ascending, Hz.
    mode_shapes: shape (n_coordinates, n_modes), mass-normalised (1/√kg), rows in the
        order of ``coordinates``.
    coordinates: names of the measurement coordinates (e.g. ``"tip:uz"``).
    metadata: ``solver``, ``mesh_size`` (elements or dofs), ``wall_time_s``,
        ``log_path`` (None for in-process solvers) and anything solver-specific.
    """

    natural_frequencies_hz: np.ndarray
    mode_shapes: np.ndarray
    coordinates: tuple[str, ...]
    metadata: Mapping[str, Any] = field(default_factory=dict)

    def to_modal_model(self, damping_ratios: float | np.ndarray = 0.0, loss_factors: float | np.ndarray = 0.0) -> ModalModel:
        """Modal model at the measurement coordinates with the given modal damping."""
        return ModalModel(
            natural_frequencies_hz=self.natural_frequencies_hz,
            mode_shapes=self.mode_shapes,
            damping_ratios=damping_ratios,
            loss_factors=loss_factors,
            dof_names=self.coordinates,
        )


def check_frequencies(frequencies_hz: np.ndarray, order_rtol: float, positive_hint: str | None = None) -> None:
    """``ValueError`` unless the natural frequencies (Hz) an FE code returned are finite,
    not negative (positive when ``positive_hint`` says what to do about a zero one) and
    ascending within ``order_rtol`` of the largest — the precision the code prints its
    results with (repeated roots may then come out a last digit apart)."""
    frequencies = np.asarray(frequencies_hz, dtype=float)
    bad = [i + 1 for i, f in enumerate(frequencies) if not np.isfinite(f)]
    if bad:
        raise ValueError(f"frequencies of mode(s) {bad} are not finite: {frequencies.tolist()} Hz")
    bad = [i + 1 for i, f in enumerate(frequencies) if f < 0 or (positive_hint is not None and not f > 0)]
    if bad:
        kind = "positive" if positive_hint is not None else "negative"
        message = (f"frequencies of mode(s) {bad} are not positive: {frequencies.tolist()} Hz ({positive_hint})"
                   if kind == "positive" else f"negative frequencies for mode(s) {bad}: {frequencies.tolist()} Hz")
        raise ValueError(message)
    slack = order_rtol * float(np.max(frequencies, initial=0.0))
    descending = [i + 1 for i in range(1, frequencies.size) if frequencies[i] < frequencies[i - 1] - slack]
    if descending:
        raise ValueError(f"frequencies are not ascending (mode(s) {descending} below the previous one): "
                         f"{frequencies.tolist()} Hz")


class AdapterError(RuntimeError):
    """An FE run failed; the message names the run directory and log."""


def parameter_key(adapter_name: str, model_fingerprint: str, parameters: Mapping[str, float]) -> str:
    """Hash of (adapter, model, parameters); parameter values are hashed exactly (repr)."""
    return fingerprint(adapter_name, model_fingerprint, {k: float(v) for k, v in parameters.items()}, length=20)


class FEAdapter(ABC):
    """Base class: parameter checks and point keys around ``_solve``."""

    name: str = "adapter"
    #: Whether an evaluation runs an external program while this process waits (several at
    #: once then overlap); an in-process evaluation holds the interpreter, so evaluations on
    #: threads beside each other only contend (:func:`nlupdate.orchestration.flows.runners.default_workers`).
    runs_a_program: bool = False

    def __init__(self, parameter_names: Sequence[str]) -> None:
        self.parameter_names = tuple(parameter_names)

    @abstractmethod
    def model_fingerprint(self) -> str:
        """A string that changes whenever the model (deck, mesh options, …) changes."""

    @abstractmethod
    def _solve(self, parameters: Mapping[str, float]) -> ModalResult:
        """Run the FE code for one parameter set."""

    def solver_version(self) -> str:
        """Name and version of the FE code, for run manifests (subclasses say more)."""
        return self.name

    def check_available(self) -> None:
        """Raise :class:`AdapterError` if the FE code cannot run here (its program is missing).

        Called before a study starts, so a missing solver is one error up front rather than
        a failure in every updating run. In-process adapters are always available.
        """

    def check_values(self, parameters: Mapping[str, float]) -> None:
        """``ValueError`` saying why the model cannot take ``parameters`` (unknown names, a
        thickness ≤ 0, …), without solving; a study checks its bounds with it before any
        work. The base class checks names and finiteness; subclasses add their model's
        ranges."""
        self._check(parameters)

    def key(self, parameters: Mapping[str, float]) -> str:
        """Identity of the point ``parameters`` of this model (checked values)."""
        return parameter_key(self.name, self.model_fingerprint(), self._check(parameters))

    def _check(self, parameters: Mapping[str, float]) -> dict[str, float]:
        unknown = set(parameters) - set(self.parameter_names)
        if unknown:
            raise ValueError(
                f"{self.name} adapter: unknown parameter(s) {sorted(unknown)}; it accepts {list(self.parameter_names)}"
            )
        checked = {}
        for name, value in parameters.items():
            value = float(value)
            if not np.isfinite(value):
                raise ValueError(f"{self.name} adapter: parameter {name!r} is not finite ({value})")
            checked[name] = value
        return checked

    def evaluate(self, parameters: Mapping[str, float]) -> ModalResult:
        """Solve the model at ``parameters`` (every call runs the FE code)."""
        return self._solve(self._check(parameters))
