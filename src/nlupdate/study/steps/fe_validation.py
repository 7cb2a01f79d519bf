"""``[fe_validation]`` of a study: the initial and the updated FE model, with the joint
identified per bolt, against every forced run of the test
(:func:`nlupdate.fe.joint_validation.validate_fe`)."""
from __future__ import annotations

from nlupdate.core.validation.forced_runs import read_forced_runs
from nlupdate.fe.adapters.registry import build_adapter
from nlupdate.fe.joint_validation import FEValidation, impact_damping, validate_fe
from nlupdate.study.spec import Study, StudyError
from nlupdate.study.steps.trust import best_run
from nlupdate.study.steps.updating import Comparison, TargetSet, UpdatingOutcome, held_at_start


def fe_validation_step(study: Study, targets: TargetSet, updating: UpdatingOutcome,
                       comparison: Comparison) -> FEValidation:
    """The study's initial model (every parameter at its start) and its best-ranked updating run,
    the joint fitted on the latter, against the runs of ``[fe_validation] file``. The test's
    frequencies pair with the FE modes ``[targets] model_modes`` (default: in order)."""
    settings = study.fe_validation
    best = best_run(updating, comparison)
    if best is None:
        raise StudyError(f"{study.path}: [fe_validation]: no updating run to take the updated model from")
    initial = held_at_start(study, ())
    updated = {**initial, **best.parameters}
    found = targets.targets
    modes = found.model_modes or tuple(range(1, len(found.frequencies_hz) + 1))
    pairing = {int(mode): float(f) for mode, f in zip(modes, found.frequencies_hz)}
    try:
        runs = read_forced_runs(study.resolve(settings.file), tuple(settings.coordinates))
        if settings.impact_file is not None:
            damping = impact_damping(study.resolve(settings.impact_file), settings.impact_channel,
                                     settings.impact_band_hz)
            source = (f"{settings.impact_file}, {settings.impact_channel} in {settings.impact_band_hz[0]:g}–"
                      f"{settings.impact_band_hz[1]:g} Hz, linear limit of the free decay")
        else:
            damping, source = settings.damping_ratio, "[fe_validation] damping_ratio"
        return validate_fe(build_adapter(study.adapter), initial, updated, pairing, runs, settings, damping, source)
    except ValueError as error:
        raise StudyError(f"{study.path}: [fe_validation]: {error}") from None
