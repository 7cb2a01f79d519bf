"""A smooth friction element, ``f = Fs·tanh(ẋ/ε)`` (NLvib's tanhDryFriction), added as one module
(src/nlupdate/core/model/elements/tanh_friction.py) and then used by every consumer of the
element registry, each against an independent reference:

* its describing function against the Fourier integral of its force law (scipy quad) and
  the viscous and Coulomb limits; its derivatives against finite differences;
* simulate: harmonic balance against time integration (its time-domain law), and the
  describing-function solver against both;
* identify: PRD recovers Fs and ε from time-integration data;
* discover: the element's own effect (``smooth_friction``, fitted when named) is found at its place.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from nlupdate.core.discovery import DiscoveryOptions, discover
from nlupdate.core.discovery.effects import EFFECT_NAMES, LIBRARY
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.dfmodels import PhysicalModel
from nlupdate.core.identification.prd import identify_prd
from nlupdate.core.measurement.frf_table import frf_table
from nlupdate.core.measurement.noise import add_table_noise
from nlupdate.core.model.elements import ELEMENT_TYPES
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.model.model_file import load_system, write_system
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.harmonic_balance import trace_harmonic_balance
from nlupdate.core.response.simulate import simulate_frf_table
from nlupdate.core.response.time_integration import steady_state_response

TanhFriction = ELEMENT_TYPES["tanh_friction"]  # registered by defining the class
TRUTH = TanhFriction((0,), slip_force=0.2, epsilon=0.02)
LINEAR = LumpedModel.with_loss_factor([[0.1]], [[2e6]], 0.01)  # 711.8 Hz
SYSTEM = NonlinearSystem(LINEAR, (TRUTH,))


def fourier_df(element, amplitude: float, omega: float) -> complex:
    """(1/(πA))∫ f(A cos θ, −Aω sin θ) e^{−iθ} dθ by adaptive quadrature of the force law."""
    def part(kind):
        def integrand(t):
            f, _ = element.force(np.array(amplitude * np.cos(t)), np.array(-amplitude * omega * np.sin(t)), None, omega)
            return float(f) * (np.cos(t) if kind == "re" else -np.sin(t))
        return quad(integrand, 0.0, 2 * np.pi, limit=400, epsabs=0.0, epsrel=1e-12)[0]
    return (part("re") + 1j * part("im")) / (np.pi * amplitude)


@pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")  # round-off at 1e-12: the check is 1e-10
@pytest.mark.parametrize("amplitude,omega", [(1e-7, 100.0), (1e-5, 2000.0), (4e-5, 4470.0), (1e-3, 4470.0)])
def test_describing_function_is_the_fourier_integral_of_the_force_law(amplitude, omega):
    nu = TRUTH.describing_function(amplitude, omega)
    assert abs(nu - fourier_df(TRUTH, amplitude, omega)) <= 1e-10 * abs(nu)


def test_viscous_and_coulomb_limits():
    w = 3000.0
    slow = TRUTH.describing_function(1e-10, w)  # Aω ≪ ε: a damper c = Fs/ε
    assert abs(slow - 1j * w * 0.2 / 0.02) <= 1e-9 * abs(slow)
    a = 1.0  # Aω ≫ ε: Coulomb 4Fs/(πA), within O((ε/Aω)²)
    fast = TRUTH.describing_function(a, w)
    assert abs(fast - 4j * 0.2 / (np.pi * a)) <= 1e-6 * abs(fast)


def test_derivatives_match_finite_differences():
    a = np.geomspace(1e-7, 1e-3, 9)
    w = np.full(a.size, 4000.0)
    d_da, d_dw = TRUTH.describing_function_derivatives(a, w)
    h = 1e-5
    fd_a = (TRUTH.describing_function(a * (1 + h), w) - TRUTH.describing_function(a * (1 - h), w)) / (2 * h * a)
    fd_w = (TRUTH.describing_function(a, w * (1 + h)) - TRUTH.describing_function(a, w * (1 - h))) / (2 * h * w)
    scale = np.abs(TRUTH.describing_function(a, w)) / a
    assert np.max(np.abs(d_da - fd_a) / scale) < 1e-7
    assert np.max(np.abs(d_dw - fd_w) / (scale * a / w)) < 1e-7


def test_model_file_round_trip(tmp_path):
    path = write_system(SYSTEM, tmp_path / "model.toml")
    assert 'type = "tanh_friction"' in path.read_text()
    assert load_system(path).elements == SYSTEM.elements


def test_harmonic_balance_agrees_with_time_integration():
    """HB (H = 5) against the steady state of the time-domain law at points of the HB curve
    across the resonance."""
    force = 1.0
    curve = trace_harmonic_balance(SYSTEM, {0: force}, 2 * np.pi * 650.0, 2 * np.pi * 780.0, harmonics=5)
    points = np.linspace(0, curve.omega.size - 1, 9).astype(int)[1:-1]
    hb = curve.response([0])[points, 0]
    ti = steady_state_response(SYSTEM, {0: np.full(points.size, force)}, curve.omega[points], tolerance=1e-10,
                               steps_per_period=128).x[:, 0]
    assert np.max(np.abs(hb - ti) / np.abs(ti)) < 1e-4  # measured 2.6e-5 (64 steps: 1.3e-4, RK4's error)


def test_describing_function_solver_agrees_with_time_integration():
    """simulate (describing functions, continuation) against time integration: a smooth
    odd law has small higher harmonics here, so the first harmonics agree closely."""
    hz = np.array([690.0, 705.0, 712.0, 730.0])
    table, _ = simulate_frf_table(SYSTEM, 0, hz, [0.3, 2.0])
    df = table["h_real"].to_numpy() + 1j * table["h_imag"].to_numpy()
    levels = table["force_level_n"].to_numpy()
    ti = steady_state_response(SYSTEM, {0: levels}, 2 * np.pi * table["frequency_hz"].to_numpy(), tolerance=1e-9).x[:, 0]
    assert np.max(np.abs(df * levels - ti) / np.abs(ti)) < 1e-2


def time_integration_table(levels, frequency_hz):
    force = np.repeat(levels, frequency_hz.size)
    frequency = np.tile(frequency_hz, len(levels))
    result = steady_state_response(SYSTEM, {0: force}, 2 * np.pi * frequency, tolerance=1e-8)
    assert result.converged.all()
    return frf_table(frequency[:, None], force[:, None], np.array([["0"]], dtype=object), "0", result.x / force[:, None])


def test_prd_identifies_slip_force_and_epsilon_from_time_integration():
    table = time_integration_table([0.01] + list(np.geomspace(0.2, 3.0, 6)), np.linspace(700.0, 722.0, 12))
    data = FRFLevels.from_table(add_table_noise(table, 0.005, 3), "0", "0")
    p = identify_prd(data, 710.0, PhysicalModel(("tanh_friction",)), estimator="improved", half_window=0.01).parameters()
    assert abs(p["slip_force"] / 0.2 - 1) < 0.01 and abs(p["epsilon"] / 0.02 - 1) < 0.02, p  # measured 2.3e-4, 1.8e-3


def test_discovery_offers_the_element_and_finds_it_at_its_place():
    """Named, the element's effect is fitted (it nests Coulomb friction and a viscous damper,
    so it is not in the default library: adding an element leaves default discovery as it was)."""
    assert "smooth_friction" in EFFECT_NAMES and "smooth_friction" not in {effect.name for effect in LIBRARY}
    model = NonlinearSystem(LumpedModel.with_loss_factor(np.diag([0.1, 0.5]), 1e6 * np.array([[2.0, -1.0], [-1.0, 2.0]]), 0.01), ())
    truth = model.with_elements((TanhFriction((1,), slip_force=0.15, epsilon=0.01),))
    natural = model.model.modes()[0] / (2 * np.pi)
    hz = np.concatenate([np.linspace(f * 0.9, f * 1.1, 14) for f in natural])
    levels = [0.2, 1.0, 4.0]
    force = np.repeat(levels, hz.size)
    x = steady_state_response(truth, {0: force}, np.tile(2 * np.pi * hz, len(levels)), tolerance=1e-7).x
    names = np.array(model.model.dof_names, dtype=object)[None, :]
    table = add_table_noise(frf_table(np.tile(hz, len(levels))[:, None], force[:, None], names, model.model.dof_names[0],
                                      x / force[:, None]), 0.01, 5)
    result = discover(model, table, DiscoveryOptions(effects=("smooth_friction", "stiffness_error", "damping_error")))
    assert [(e.name, e.dofs) for e in result.effects] == [("smooth_friction", (1,))], result.stop_reason
    assert result.gap_after.gap <= 0.3 * result.gap_before.gap
    found = result.effects[0].parameters
    assert abs(found["slip_force"] / 0.15 - 1) < 0.1, found
