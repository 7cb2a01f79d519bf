"""The built-in beam surrogate against the solid C3D20R CalculiX T-beam (real ccx runs).

Two independent discretisations of the same structure (Timoshenko frame elements with
rigid joint links vs 20-node solids sharing nodes at the sandwich) must give the same
first three global natural frequencies within 3 %, at the nominal design and at an
updated design with sensor masses.
"""
import numpy as np
import pytest

from nlupdate.fe.adapters.calculix import CalculixAdapter
from nlupdate.fe.adapters.calculix_tbeam import TBEAM_PARAMETER_NAMES, TBeamDeck, TBeamMesh, global_modes
from nlupdate.fe.adapters.surrogate import SurrogateAdapter

DESIGNS = [
    {},
    {"E": 189.4e9, "h1": 7.727e-3, "h2": 1.6e-3, "transducer_mass": 0.0302, "accelerometer_mass": 0.0048},
]


@pytest.mark.calculix
@pytest.mark.parametrize("design", DESIGNS, ids=["nominal", "candidate-1-with-sensors"])
def test_surrogate_matches_solid_calculix_tbeam(tmp_path, design):
    solid = CalculixAdapter(TBeamDeck(TBeamMesh(2, 2, 40, 1, 2, 20)), TBEAM_PARAMETER_NAMES, n_modes=8, work_root=tmp_path)
    surrogate = SurrogateAdapter("tbeam", n_modes=3, global_modes_only=True)
    solid_result = solid.evaluate(design)
    f_solid = solid_result.natural_frequencies_hz[global_modes(solid_result, design)[:3]]
    f_beam = surrogate.evaluate(design).natural_frequencies_hz[:3]
    print(f"\n{design or 'nominal'}: surrogate {f_beam.round(2)} Hz, CalculiX C3D20R {f_solid.round(2)} Hz, "
          f"difference {(100 * (f_beam / f_solid - 1)).round(2)} %")
    np.testing.assert_allclose(f_beam, f_solid, rtol=0.03)
