"""Every parameter of a physical describing-function model has its own reported name.

Jenkins and Coulomb both have a ``slip_force``: the model fitted three numbers but reported
two, ``{kf, slip_force}``, one slip force lost. Here every pair of element types (and a
repeated pair) is checked: the names are distinct, each value set through them comes back
under its own name, and the model's elements are the ones built directly from those values
(the describing function compared with the elements constructed by hand, an independent
path through the element classes).
"""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from nlupdate.core.identification.dfmodels import ELEMENT_PARAMETERS, INTERVAL_PARAMETERS, PhysicalModel
from nlupdate.core.model.elements import ELEMENT_TYPES

#: a value per declared parameter name inside its interval, positive where it must be
VALUES = {"k3": 3e9, "kf": 3e4, "slip_force": 0.5, "epsilon": 1e-3, "cq": 2.0, "gap": 1e-4, "kc": 5e5,
          "kt": 4e4, "chi": -0.4, "beta": 0.3}


def distinct(base: str, index: int) -> float:
    """The value of a parameter ``base`` of the element at ``index``: each copy its own."""
    return VALUES[base] * (1.0 + 0.1 * index) if base not in INTERVAL_PARAMETERS else VALUES[base] + 0.05 * index


FITTED = [name for name in ELEMENT_TYPES if name in ELEMENT_PARAMETERS and name != "polynomial"]


@pytest.mark.parametrize("pair", list(itertools.combinations_with_replacement(FITTED, 2))
                         + [("jenkins", "jenkins", "coulomb", "coulomb")], ids="+".join)
def test_each_parameter_of_two_elements_is_reported_under_its_own_name(pair):
    model = PhysicalModel(pair)
    assert len(set(model.names)) == len(model.names) == sum(len(ELEMENT_PARAMETERS[e]) for e in pair), model.names
    values, by_element = [], []
    for index, (element, _) in enumerate(model._suffixes()):
        own = {name: distinct(name, index) for name, _ in ELEMENT_PARAMETERS[element]}
        by_element.append(own)
    for (element, suffix), own in zip(model._suffixes(), by_element):
        values += [own[name] for name, _ in ELEMENT_PARAMETERS[element]]
    p = model.vector(values)
    reported = model.parameters(p)
    assert sorted(reported.values()) == pytest.approx(sorted(values), rel=1e-9)  # none lost, none doubled
    amplitude, omega = np.array([1e-5, 3e-5, 1e-4, 1e-3]), 2 * np.pi * 100.0
    built = [ELEMENT_TYPES[element]((0,), **own) for element, own in zip(pair, by_element)]
    expected = sum(e.describing_function(amplitude, omega) for e in built)
    got = sum(e.describing_function(amplitude, omega) for e in model.elements(p))
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-12 * np.max(np.abs(expected)))


def test_names_that_clash_across_types_carry_the_type_and_others_keep_their_short_names():
    assert PhysicalModel(("jenkins", "coulomb")).names == ("kf_jenkins", "slip_force_jenkins", "slip_force_coulomb")
    assert PhysicalModel(("cubic", "jenkins", "jenkins")).names == ("k3", "kf_1", "slip_force_1", "kf_2",
                                                                     "slip_force_2")
    assert PhysicalModel(("cubic", "jenkins")).names == ("k3", "kf", "slip_force")


@pytest.mark.parametrize("elements", list(itertools.combinations_with_replacement(FITTED, 2))
                         + [("jenkins", "jenkins", "coulomb", "coulomb")], ids="+".join)
def test_each_reported_name_has_the_unit_its_element_declares(elements):
    """``slip_force_coulomb``, ``kf_jenkins1``, ``epsilon_tanh_friction`` are printed and written
    to identification.json with the unit of ``slip_force``, ``kf``, ``epsilon`` (they had none:
    the units looked up only a copy's number), also with volts for newtons."""
    from nlupdate.core.measurement.units import parameter_unit

    model = PhysicalModel(elements)
    for element, suffix in model._suffixes():
        for parameter in ELEMENT_TYPES[element].parameters:
            if parameter.fitted:
                for reference in ("N", "V"):
                    assert parameter_unit(parameter.name + suffix, reference) == parameter_unit(parameter.name, reference), \
                        (parameter.name + suffix, reference)
