"""The study's ``[fe_validation]`` table: the updated FE model, with a joint element per bolt
identified from the force-controlled runs, against every forced run of the test.

One declaration (:mod:`nlupdate.settings`): the study reader checks the table from it and
docs/study-files.md's table of keys is generated from it. Paths are as written in the
study (relative to the study file); the study resolves and archives them.
"""
from __future__ import annotations

from dataclasses import dataclass

from nlupdate.settings import setting

#: How a run was controlled: the force set per level, or the drive point's response amplitude held.
CONTROLS = ("force", "response")
#: The friction elements one bolt may carry along the interface (their stuck stiffness is the
#: FE model's tangential joint stiffness ``kt``).
JOINT_ELEMENTS = ("iwan", "jenkins")


@dataclass(frozen=True)
class FEValidationSettings:
    """Which runs, which joint element and how hard to fit it (each field: its declaration)."""

    file: str = setting(kind="path", required=True, flag="",
                        meaning="the MATLAB stepped-sine file of the forced runs (force- and response-controlled)")
    coordinates: tuple[str, ...] = setting(
        ("acc3:-y", "acc3:y"), kind="strings", length=2, flag="",
        meaning="(response, input) names of the file's curve, as `--coordinates` takes them")
    drive_dof: str = setting("acc3:uy", kind="string", flag="",
                             meaning="the model coordinate the shaker drives and the curve is measured at")
    runs: tuple[str, ...] = setting(("force", "response"), kind="strings", flag="",
                                    meaning='which runs to predict: "force", "response" or both (the joint is '
                                            "always fitted to the force-controlled runs)")
    element: str = setting("iwan", kind="choice", choices=JOINT_ELEMENTS,
                           meaning="the friction element per bolt along the interface: Segalman's Iwan (slip force, "
                                   "χ; β = 0) or Jenkins (slip force)")
    fit_evaluations: int = setting(60, kind="integer", minimum=1, unit="model evaluations",
                                   meaning="most evaluations of the joint fit (each predicts every force-controlled run)")
    impact_file: str | None = setting(
        None, kind="path", flag="", default_text="none: `damping_ratio`",
        meaning="hammer-impact record (.mat, struct HIdata with time and one field per channel) whose free decay "
                "gives the starting linear damping ratio (output-only linear limit)")
    impact_channel: str = setting("acc3", kind="string", flag="", meaning="the impact record's channel to fit")
    impact_band_hz: tuple[float, ...] = setting((72.0, 88.0), kind="numbers", length=2, minimum=0, unit="Hz", flag="",
                                                meaning="band of the first mode in the impact record")
    damping_ratio: float = setting(0.0015, kind="number", minimum=0, maximum=0.2, above_minimum=True, flag="",
                                   meaning="starting linear damping ratio when no `impact_file` is given")
    shaker_mass: bool = setting(True, kind="boolean", flag="",
                                meaning="add the shaker's moving mass at the drive point: the mass that moves mode 1 "
                                        "from the impact frequency (the first target) to the lowest force-controlled "
                                        "run's resonance")
    margin_hz: float = setting(2.5, kind="number", minimum=0, unit="Hz", flag="",
                               meaning="the prediction grid extends the tested band by this much at each end")

    def __post_init__(self) -> None:
        unknown = sorted(set(self.runs) - set(CONTROLS))
        if unknown or not self.runs:
            raise ValueError(f"runs: expected a non-empty list of {list(CONTROLS)}, got {list(self.runs)}")
        low, high = self.impact_band_hz
        if not 0 < low < high:
            raise ValueError(f"impact_band_hz {list(self.impact_band_hz)}: expected LOW < HIGH, both > 0 Hz")
