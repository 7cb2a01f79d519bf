"""Fitting candidate effects to stepped-sine FRFs at one place (output error, per point).

Background. Everything of the current model that is not at the place u is the background:
its linear model, and its nonlinear elements frozen at each point at their DF value for
the amplitude the test measured (or, at unmeasured coordinates, the current model's
amplitude) — the PRD idea of evaluating DFs at measured amplitudes (docs/methods.md §4). The
background receptance at a point is then ``H = (I + H^L Δ)⁻¹ H^L`` on the coordinates
needed (measured, forced, the place).

Place. The DF at u is the sum of the user's elements there (fixed), the effects found
earlier there (refitted) and the candidate. Condensed on u the harmonic balance is scalar
(docs/methods.md §3): ``x_u (1 + H_uu ν(A)) = H_uf F`` with ``A = |x_u|``, i.e.
``A·|1/H_uu + ν(A)| = |H_uf/H_uu|·F``, solved for the root nearest the measured amplitude
(:func:`nlupdate.core.identification.scalar_balance.nearest_amplitude`, as PRD's improved estimator
does); then ``X_m = H_mf F − H_mu ν x_u``. The residuals ``(X_m − X̃_m)/|X̃_m|`` follow the
noise model, so the least-squares fit is the maximum-likelihood estimate without
errors in variables (the force is exact, the amplitude is solved, not measured).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.discovery.candidates import CandidateFit, FoundEffect
from nlupdate.core.discovery.effects import DFSamples, Effect
from nlupdate.core.discovery.fitting import fit_at_place
from nlupdate.core.discovery.localisation import Localisation, free_element_force, summarise
from nlupdate.core.identification.scalar_balance import RootSensitivity, nearest_amplitude
from nlupdate.core.model.system import NonlinearSystem

DF = Callable[[NDArray, NDArray], NDArray]


def _relative(x: Callable[[int], NDArray], dofs: Sequence[int]) -> NDArray[np.complex128]:
    return x(dofs[0]) - (x(dofs[1]) if len(dofs) == 2 else 0.0)


def background_receptance(
    system: NonlinearSystem, omega: NDArray, coords: Sequence[int], x_reference: Callable[[int], NDArray]
) -> NDArray[np.complex128]:
    """Receptances (n_points, len(coords), len(coords)) of ``system`` with its elements frozen
    at the DF of the amplitudes ``x_reference(dof)`` (complex, per point) — see module doc."""
    coords = list(coords)
    element_dofs = sorted({d for e in system.elements for d in e.dofs} - set(coords))
    every = coords + element_dofs
    h = system.model.receptance(omega, every, every)
    if not system.elements:
        return h
    position = {dof: i for i, dof in enumerate(every)}
    delta = np.zeros_like(h)
    for element in system.elements:
        nu = element.describing_function(np.abs(_relative(x_reference, element.dofs)), omega)
        r = position[element.dofs[0]]
        delta[:, r, r] += nu
        if len(element.dofs) == 2:
            j = position[element.dofs[1]]
            delta[:, j, j] += nu
            delta[:, r, j] -= nu
            delta[:, j, r] -= nu
    frozen = np.linalg.solve(np.eye(len(every)) + h @ delta, h)
    return frozen[:, : len(coords), : len(coords)]


def _sum_df(terms: Sequence[tuple[Callable, NDArray | None]]) -> DF:
    """``ν(A, ω)`` of fixed elements (values None) and effects with values."""

    def nu(amplitude, omega):
        total = 0.0
        for function, values in terms:
            total = total + (function(amplitude, omega) if values is None else function(values, amplitude, omega))
        return np.broadcast_to(total, np.broadcast_shapes(np.shape(amplitude), np.shape(omega))).astype(complex)

    return nu


@dataclass(frozen=True, eq=False)
class FRFContext:
    """Everything needed to fit candidates at one place (arrays per point, see module doc).

    h_mf, h_mu: (n, m) background receptances from the force and from the place to the
    measured coordinates; h_uf, h_uu: (n,) from the force and the place to the place;
    x_measured (n, m) and u_measured (n,) measured amplitudes (m); fixed: the user's
    elements at the place; companions: effects found earlier at the place; chi2_scale:
    ``2/σ²`` per measured value (n, m), σ its relative noise std; penalty: criterion cost
    per parameter.
    """

    dofs: tuple[int, ...]
    omega: NDArray[np.float64]
    force: NDArray[np.float64]
    x_measured: NDArray[np.complex128]
    u_measured: NDArray[np.complex128]
    h_mf: NDArray[np.complex128]
    h_mu: NDArray[np.complex128]
    h_uf: NDArray[np.complex128]
    h_uu: NDArray[np.complex128]
    fixed: tuple
    companions: tuple[FoundEffect, ...]
    chi2_scale: NDArray[np.float64]
    penalty: float
    samples: DFSamples
    localisation: Localisation

    @property
    def n_data(self) -> int:
        return 2 * self.x_measured.size

    def _terms(self, effects: Sequence[Effect], values: Sequence[NDArray]) -> list:
        return [(element.describing_function, None) for element in self.fixed] + [
            (effect.nu, v) for effect, v in zip(effects, values)
        ]

    def linearise(self, effects: Sequence[Effect], values: Sequence[NDArray]) -> "PlaceSolution":
        """The amplitude at the place solved with these effects (at ``values``): gives the
        residual and its Jacobian from one solve."""
        nu = _sum_df(self._terms(effects, values))
        w = 1.0 / self.h_uu
        amplitude, solved = nearest_amplitude(
            w, nu, self.force * np.abs(self.h_uf * w), self.omega, np.abs(self.u_measured)
        )
        return PlaceSolution(self, tuple(effects), nu, amplitude, solved)

    def predict(self, effects: Sequence[Effect] = (), values: Sequence[NDArray] = ()) -> NDArray[np.complex128]:
        """Amplitudes (n, m) at the measured coordinates with these effects at the place."""
        if not self._terms(effects, values):
            return self.h_mf * self.force[:, None]
        return self.linearise(effects, values).predict()

    def residual(self, effects: Sequence[Effect], values: Sequence[NDArray]) -> NDArray[np.float64]:
        """Residuals scaled to unit noise std: ``Σ r² = χ²``."""
        return self._scaled(self.predict(effects, values) - self.x_measured)

    def _scaled(self, difference: NDArray[np.complex128]) -> NDArray[np.float64]:
        r = np.sqrt(self.chi2_scale) * difference / np.abs(self.x_measured)
        return np.concatenate([r.real.ravel(), r.imag.ravel()])

    def fit(self, effect: Effect) -> CandidateFit:
        """Fit ``effect`` here (see :func:`nlupdate.core.discovery.fitting.fit_at_place`)."""
        return fit_at_place(self, effect)



@dataclass(frozen=True, eq=False)
class PlaceSolution:
    """One amplitude solve of an :class:`FRFContext`: ν (the DF at the place), A (m) and
    whether each point has a root (:func:`~nlupdate.core.identification.scalar_balance.nearest_amplitude`)."""

    context: FRFContext
    effects: tuple[Effect, ...]
    nu: DF
    amplitude: NDArray[np.float64]
    solved: NDArray[np.bool_]

    def predict(self) -> NDArray[np.complex128]:
        """``X_m = H_mf F − H_mu ν u`` (n, m) with ``u = H_uf F/(1 + H_uu ν)``."""
        c = self.context
        value = self.nu(self.amplitude, c.omega)
        u = c.h_uf * c.force / (1.0 + c.h_uu * value)
        return c.h_mf * c.force[:, None] - c.h_mu * (value * u)[:, None]

    def residual(self) -> NDArray[np.float64]:
        """As :meth:`FRFContext.residual`."""
        return self.context._scaled(self.predict() - self.context.x_measured)

    def jacobian(self, perturbed: Sequence[Sequence[NDArray]], steps: NDArray) -> NDArray[np.float64]:
        """∂r/∂θ_j of :meth:`residual` for unknowns θ_j whose step ``steps[j]`` turns the
        values into ``perturbed[j]``, without another amplitude solve.

        The amplitude at the place follows θ implicitly
        (:class:`~nlupdate.core.identification.scalar_balance.RootSensitivity`, with
        ``s = 1/H_uu + ν(A, θ)``): ``dν = ν_θ + ν_A dA``, then
        ``dX_m = −H_mu H_uf F/(1 + H_uu ν)² dν``. ν_θ is a forward difference of the DF
        alone, at the solved amplitude."""
        c, amplitude = self.context, self.amplitude
        value = self.nu(amplitude, c.omega)
        root = RootSensitivity.at(1.0 / c.h_uu, self.nu, amplitude, c.omega, self.solved)
        d_value = c.h_uf * c.force / (1.0 + c.h_uu * value) ** 2
        columns = []
        for stepped, step in zip(perturbed, steps):
            nu_theta = (_sum_df(c._terms(self.effects, stepped))(amplitude, c.omega) - value) / step
            columns.append(c._scaled(-c.h_mu * (d_value * root.d_s(nu_theta))[:, None]))
        return np.stack(columns, axis=1)


def frf_context(
    background: NonlinearSystem,
    fixed: tuple,
    companions: tuple[FoundEffect, ...],
    dofs: tuple[int, ...],
    input_dof: int,
    response_dofs: tuple[int, ...],
    omega: NDArray,
    force: NDArray,
    level_index: NDArray,
    x_measured: NDArray,
    x_reference: Callable[[int], NDArray],
    chi2_scale: NDArray | float,
    penalty: float,
    current_misfit: float | None = None,
) -> FRFContext:
    """Build the context of one place: background receptances, the free element force
    (localisation) and the apparent DF samples less the user's elements there.

    ``current_misfit``: χ² of the current model (every effect found so far, also those at
    this place); the place's ``explained`` is then the share of *that* misfit a free element
    here removes — what the place explains beyond what is already explained. Without it,
    the share of the background's misfit (the model without the effects at this place)."""
    chi2_scale = np.broadcast_to(np.asarray(chi2_scale, dtype=float), np.shape(x_measured))
    coords = list(dict.fromkeys(list(response_dofs) + [input_dof] + list(dofs)))
    h = background_receptance(background, omega, coords, x_reference)
    at = {dof: i for i, dof in enumerate(coords)}
    m = [at[d] for d in response_dofs]
    f = at[input_dof]

    def column(rows: list[int] | int, place: tuple[int, ...]) -> NDArray:
        out = h[:, rows, at[place[0]]]
        return out - h[:, rows, at[place[1]]] if len(place) == 2 else out

    h_mf, h_mu = h[:, m, f], column(m, dofs)
    h_uf = h[:, at[dofs[0]], f] - (h[:, at[dofs[1]], f] if len(dofs) == 2 else 0.0)
    h_uu = column(at[dofs[0]], dofs) - (column(at[dofs[1]], dofs) if len(dofs) == 2 else 0.0)
    measured_at = {dof: x_measured[:, k] for k, dof in enumerate(response_dofs)}
    u = _relative(measured_at.__getitem__, dofs)
    g, explained = free_element_force(h_mf, h_mu, x_measured, force, np.sqrt(chi2_scale), current_misfit)
    nu = g / u
    spread = np.sqrt(sum(np.abs(measured_at[d]) ** 2 for d in dofs)) / np.abs(u)
    amplitude = np.abs(u)
    fixed_df = _sum_df([(e.describing_function, None) for e in fixed])
    samples = DFSamples(
        amplitude=amplitude,
        omega=omega,
        nu=nu - (fixed_df(amplitude, omega) if fixed else 0.0),
        std=np.abs(nu + 1.0 / h_uu) * spread,
    )
    localisation = summarise(dofs, explained, level_index, DFSamples(amplitude, omega, nu, samples.std))
    return FRFContext(
        dofs, omega, force, x_measured, u, h_mf, h_mu, h_uf, h_uu, tuple(fixed), tuple(companions),
        chi2_scale, penalty, samples, localisation,
    )
