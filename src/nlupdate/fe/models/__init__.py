"""Built-in finite-element surrogate: 3D frame elements and the thesis case models.

* :mod:`nlupdate.fe.models.frame` — the frame model builder (nodes, elements, constraints, naming);
  its elements in :mod:`~nlupdate.fe.models.frame_elements`, its assembly and constraints in
  :mod:`~nlupdate.fe.models.frame_assembly`, its modal solution in :mod:`~nlupdate.fe.models.frame_modal`.
* :mod:`nlupdate.fe.models.tbeam` — the T-beam test structure (thesis §3.3, §4).
* :mod:`nlupdate.fe.models.gunbarrel` — the gun barrel (thesis §5.11), with assumed dimensions.
* :mod:`nlupdate.fe.models.mesh_study` — frequency convergence with mesh refinement.
"""
from nlupdate.fe.models.frame import DOF_NAMES, FrameModel, Material, ModalSolution, Section
from nlupdate.fe.models.gunbarrel import GUNBARREL_COORDINATES, GunBarrelParameters, gunbarrel_model
from nlupdate.fe.models.mesh_study import mesh_refinement_study
from nlupdate.fe.models.tbeam import (
    TBEAM_COORDINATES,
    TBeamParameters,
    global_frequencies,
    global_mode_mask,
    global_modes,
    tbeam_model,
)

__all__ = [
    "DOF_NAMES",
    "GUNBARREL_COORDINATES",
    "TBEAM_COORDINATES",
    "FrameModel",
    "GunBarrelParameters",
    "Material",
    "ModalSolution",
    "Section",
    "TBeamParameters",
    "global_frequencies",
    "global_mode_mask",
    "global_modes",
    "gunbarrel_model",
    "mesh_refinement_study",
    "tbeam_model",
]
