"""A small built-in spring–mass chain behind the :class:`FEAdapter` interface.

The chain is ``ground –k1– m1 –k2– m2 – … – mn`` and, when ``stiffnesses`` has n + 1
entries, ``mn –k(n+1)– ground``. Masses in kg, stiffnesses in N/m. Every mass and
spring is an updating parameter, named ``m1 … mn`` and ``k1 … k(n+1)``; values not
given to :meth:`FEAdapter.evaluate` keep the defaults passed to the constructor.
Coordinates are named ``x1 … xn`` (displacement of mass i along the chain).

It exists so the updating machinery can be tested against an exact, instant model:
natural frequencies and mass-normalised mode shapes come from the dense generalised
eigenproblem ``K φ = ω² M φ`` (:meth:`nlupdate.core.model.linear.LumpedModel.modes`).
"""
from __future__ import annotations

import time
from typing import Mapping, Sequence

import numpy as np

from nlupdate.fingerprints import fingerprint
from nlupdate.fe.adapters.base import FEAdapter, ModalResult
from nlupdate.core.model.linear import LumpedModel


class LumpedAdapter(FEAdapter):
    """Spring–mass chain; see the module docstring for topology and names."""

    name = "lumped"

    def __init__(
        self,
        masses: Sequence[float],
        stiffnesses: Sequence[float],
    ) -> None:
        masses = [float(m) for m in masses]
        stiffnesses = [float(k) for k in stiffnesses]
        n = len(masses)
        if n < 1:
            raise ValueError("lumped adapter: 'masses' needs at least one entry (kg)")
        if len(stiffnesses) not in (n, n + 1):
            raise ValueError(
                f"lumped adapter: 'stiffnesses' needs {n} or {n + 1} entries (N/m) for {n} masses, "
                f"got {len(stiffnesses)}"
            )
        if any(not m > 0 for m in masses) or any(not k > 0 for k in stiffnesses):
            raise ValueError("lumped adapter: masses and stiffnesses must be positive")
        self.defaults = {f"m{i + 1}": m for i, m in enumerate(masses)}
        self.defaults.update({f"k{i + 1}": k for i, k in enumerate(stiffnesses)})
        self.n_masses = n
        self.n_springs = len(stiffnesses)
        super().__init__(tuple(self.defaults))

    @property
    def coordinates(self) -> tuple[str, ...]:
        return tuple(f"x{i + 1}" for i in range(self.n_masses))

    def model_fingerprint(self) -> str:
        return fingerprint({"defaults": self.defaults}, length=16)

    def solver_version(self) -> str:
        return "nlupdate lumped chain (scipy.linalg.eigh)"

    def matrices(self, parameters: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
        """Mass (kg) and stiffness (N/m) matrices for ``parameters`` over the defaults."""
        values = {**self.defaults, **{k: float(v) for k, v in parameters.items()}}
        for name, value in values.items():
            if not value > 0:
                raise ValueError(f"lumped adapter: parameter {name!r} must be positive, got {value}")
        n = self.n_masses
        mass = np.diag([values[f"m{i + 1}"] for i in range(n)])
        stiffness = np.zeros((n, n))
        for spring in range(self.n_springs):
            k = values[f"k{spring + 1}"]
            left, right = spring - 1, spring  # mass indices at the ends (-1 or n: ground)
            for i in (left, right):
                if 0 <= i < n:
                    stiffness[i, i] += k
            if 0 <= left < n and 0 <= right < n:
                stiffness[left, right] -= k
                stiffness[right, left] -= k
        return mass, stiffness

    def check_values(self, parameters: Mapping[str, float]) -> None:
        self.matrices(self._check(parameters))

    def _solve(self, parameters: Mapping[str, float]) -> ModalResult:
        start = time.perf_counter()
        mass, stiffness = self.matrices(parameters)
        omega, phi = LumpedModel(mass, stiffness).modes()
        return ModalResult(
            natural_frequencies_hz=omega / (2 * np.pi),
            mode_shapes=phi,
            coordinates=self.coordinates,
            metadata={
                "solver": "lumped (scipy.linalg.eigh)",
                "mesh_size": self.n_masses,
                "wall_time_s": time.perf_counter() - start,
                "log_path": None,
            },
        )


def from_options(model: str | None, options: dict) -> LumpedAdapter:
    """The adapter of a study's ``[adapter] kind = "lumped"`` (:mod:`nlupdate.fe.adapters.registry`)."""
    try:
        return LumpedAdapter(options.pop("masses"), options.pop("stiffnesses"), **options)
    except KeyError as error:
        raise ValueError(f"lumped adapter: missing option {error.args[0]!r} (list of masses in kg / stiffnesses in N/m)") from None
    except TypeError as error:
        raise ValueError(f"lumped adapter: {error}") from None
