"""Mesh-refinement study of the T-beam: beam surrogate and solid CalculiX model.

Prints the first three global natural frequencies (Hz) against element count for the
built-in Timoshenko frame surrogate and for the C3D20R CalculiX deck (needs ``ccx``),
plus the gun-barrel surrogate. ``--quick`` skips the two finest CalculiX meshes.

    python benchmarks/mesh_study.py [--quick]
"""
from __future__ import annotations

import argparse
import shutil
import tempfile

import pandas as pd

from nlupdate.fe.adapters.calculix_tbeam import TBeamMesh, mesh_study
from nlupdate.fe.models import GunBarrelParameters, TBeamParameters, global_frequencies, gunbarrel_model, mesh_refinement_study, tbeam_model


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="skip the finest CalculiX meshes")
    args = parser.parse_args()
    pd.set_option("display.width", 160)

    print("T-beam surrogate (Timoshenko frame elements), first three global modes, no sensor masses")
    table = mesh_refinement_study(tbeam_model, TBeamParameters(), [4, 8, 16, 32, 64], 3, frequencies=global_frequencies)
    print(table.pivot_table(index=["mesh_parameter", "elements", "dofs"], columns="mode", values="frequency_hz").round(3).to_string())

    print("\nGun-barrel surrogate, first three modes")
    table = mesh_refinement_study(gunbarrel_model, GunBarrelParameters(), [8, 16, 32, 64], 3)
    print(table.pivot_table(index=["mesh_parameter", "elements", "dofs"], columns="mode", values="frequency_hz").round(4).to_string())

    if shutil.which("ccx") is None:
        print("\nCalculiX (ccx) not found: apt-get install calculix-ccx to run the solid-model study")
        return
    meshes = [TBeamMesh(1, 1, 20, 1, 1, 10), TBeamMesh(2, 2, 40, 1, 2, 20), TBeamMesh(2, 2, 60, 1, 2, 30)]
    if not args.quick:
        meshes += [TBeamMesh(3, 3, 80, 2, 3, 40), TBeamMesh(4, 4, 100, 2, 4, 50)]
    print("\nT-beam solid model (CalculiX C3D20R), first three global modes, no sensor masses")
    with tempfile.TemporaryDirectory() as work:
        table = mesh_study(meshes, work_root=work)
    print(table.drop(columns=["all_frequencies_hz"]).round({"f1_hz": 3, "f2_hz": 3, "f3_hz": 3, "wall_time_s": 2}).to_string(index=False))


if __name__ == "__main__":
    main()
