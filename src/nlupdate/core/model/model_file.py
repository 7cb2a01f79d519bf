"""TOML model descriptions: a linear model plus ``[[nonlinear]]`` elements.

Lumped form (matrices in SI units; ``damping`` viscous N·s/m, ``loss_factor`` gives
structural damping ``D = loss_factor·K``, ``structural_damping`` gives D directly)::

    [model]
    kind = "lumped"
    mass = [[0.1, 0.0], [0.0, 0.5]]
    stiffness = [[2e6, -1e6], [-1e6, 2e6]]
    damping = [[0.0, 0.0], [0.0, 0.0]]     # optional
    loss_factor = 0.005                    # optional
    dof_names = ["m1", "m2"]               # optional, default "0", "1", …

Modal form (mass-normalised shapes, one row per coordinate)::

    [model]
    kind = "modal"
    natural_frequencies_hz = [712.0, 1500.0]
    mode_shapes = [[3.1, 0.2], [0.5, -2.0]]
    damping_ratios = [0.005, 0.005]        # optional (or one number)
    loss_factors = 0.0                     # optional

Elements (``dofs`` = one dof to ground or two dofs, by index or name)::

    [[nonlinear]]
    type = "jenkins"
    dofs = [0]
    kf = 8e4
    slip_force = 1.0

    [[nonlinear]]                          # Segalman's four-parameter Iwan joint
    type = "iwan"
    dofs = [0, 1]
    slip_force = 1.0                       # F_S, macroslip force (N)
    kt = 3e5                               # K_T, tangential stiffness (N/m)
    chi = -0.5                             # χ, −1 < χ ≤ 0
    beta = 0.5                             # β ≥ 0
    sliders = 400                          # optional: Jenkins sliders in time integration

:func:`system_to_toml` / :func:`write_system` write a system in this form (dense matrices,
``structural_damping`` as a matrix, floats in shortest round-trip form) so that
:func:`load_system` reads back the same model.
"""
from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import scipy.sparse

from nlupdate.core.model.elements import ELEMENT_TYPES
from nlupdate.core.model.linear import LumpedModel, ModalModel, dof_index
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.files import atomic_file
from nlupdate.input_files import parse_toml, read_input_text

LUMPED_KEYS = {"kind", "mass", "stiffness", "damping", "loss_factor", "structural_damping", "dof_names"}
MODAL_KEYS = {"kind", "natural_frequencies_hz", "mode_shapes", "damping_ratios", "loss_factors", "dof_names"}


class ModelFileError(ValueError):
    """A model file that cannot be used; the message names file, table and key."""


def _require(table: Mapping[str, Any], key: str, where: str) -> Any:
    if key not in table:
        raise ModelFileError(f"{where}: missing key '{key}'")
    return table[key]


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _numbers(value: Any, key: str, where: str, form: str) -> np.ndarray:
    """``value`` as floats if it holds only TOML numbers (a string such as "1e10" is refused)."""
    def check(item: Any) -> None:
        if isinstance(item, list):
            for entry in item:
                check(entry)
        elif not _is_number(item):
            raise ModelFileError(f"{where}: '{key}' must be {form}; found {item!r} ({type(item).__name__}) — write "
                                 f"numbers without quotes, e.g. 1e10")
    check(value)
    try:
        return np.array(value, dtype=float)
    except ValueError:
        raise ModelFileError(f"{where}: '{key}' must be {form}") from None


#: The largest magnitude a model's number may have in SI units (anything larger is a unit
#: mistake, and squares of it overflow).
MAX_MAGNITUDE = 1e30


def _matrix(table: Mapping[str, Any], key: str, where: str) -> np.ndarray:
    matrix = _numbers(_require(table, key, where), key, where, "a square matrix of numbers (list of rows)")
    if matrix.ndim != 2 or matrix.shape[0] != matrix.shape[1]:
        raise ModelFileError(f"{where}: '{key}' must be a square matrix (list of equal-length rows), got shape {matrix.shape}")
    bad = np.argwhere(~np.isfinite(matrix) | (np.abs(matrix) > MAX_MAGNITUDE))
    if len(bad):
        i, j = bad[0]
        problem = "not a finite number" if not np.isfinite(matrix[i, j]) else f"larger than {MAX_MAGNITUDE:g} (SI units?)"
        raise ModelFileError(f"{where}: '{key}' row {i}, column {j} is {matrix[i, j]:g}: {problem}")
    return matrix


def _dof_names(table: Mapping[str, Any], where: str) -> tuple[str, ...]:
    """The optional ``dof_names``: distinct strings (numbers are taken as their text)."""
    names = table.get("dof_names", [])
    if not isinstance(names, list) or any(not isinstance(n, (str, int)) or isinstance(n, bool) for n in names):
        raise ModelFileError(f"{where}: 'dof_names' must be a list of names (strings), got {names!r}")
    names = tuple(str(n) for n in names)
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise ModelFileError(f"{where}: 'dof_names' names {repeated[0]!r} more than once; every dof needs its own name")
    return names


def _check_definite(matrix: np.ndarray, key: str, where: str, positive: bool, meaning: str) -> None:
    """Symmetric and positive (semi-)definite, else one error naming the key and the fault."""
    scale = float(np.max(np.abs(matrix))) if matrix.size else 0.0
    if not np.allclose(matrix, matrix.T, rtol=1e-10, atol=1e-12 * scale):
        raise ModelFileError(f"{where}: '{key}' must be symmetric")
    if positive:
        diagonal = np.diag(matrix)
        if np.any(diagonal <= 0):
            i = int(np.argmax(diagonal <= 0))
            raise ModelFileError(f"{where}: '{key}' has {diagonal[i]:g} on the diagonal at dof {i}; {meaning}")
    lowest = float(np.linalg.eigvalsh(matrix).min()) if matrix.size else 0.0
    if lowest <= 0 if positive else lowest < -1e-9 * scale:
        kind = "positive definite" if positive else "positive semi-definite"
        raise ModelFileError(f"{where}: '{key}' must be {kind} ({meaning}); its lowest eigenvalue is {lowest:.4g}")


def _non_negative(table: Mapping[str, Any], key: str, where: str, default: float = 0.0) -> np.ndarray:
    values = _numbers(table.get(key, default), key, where, "a number ≥ 0 or a list of them")
    if np.any(~np.isfinite(values)) or np.any(values < 0):
        raise ModelFileError(f"{where}: '{key}' must be ≥ 0 (a negative value would feed energy in), got {table[key]!r}")
    return values


def linear_model_from_table(table: Mapping[str, Any], where: str) -> LumpedModel | ModalModel:
    """Build the linear model from the ``[model]`` table."""
    kind = _require(table, "kind", where)
    if kind == "lumped":
        unknown = set(table) - LUMPED_KEYS
        if unknown:
            raise ModelFileError(f"{where}: unknown key(s) {sorted(unknown)}; a lumped model accepts {sorted(LUMPED_KEYS)}")
        mass = _matrix(table, "mass", where)
        stiffness = _matrix(table, "stiffness", where)
        damping = _matrix(table, "damping", where) if "damping" in table else None
        structural = _matrix(table, "structural_damping", where) if "structural_damping" in table else None
        _check_definite(mass, "mass", where, True, "every mass must be positive (kg)")
        _check_definite(stiffness, "stiffness", where, False, "a negative eigenvalue is an unstable structure")
        for key, matrix in (("damping", damping), ("structural_damping", structural)):
            if matrix is not None:
                _check_definite(matrix, key, where, False, "negative damping would feed energy in")
        if "loss_factor" in table:
            if structural is not None:
                raise ModelFileError(f"{where}: give either 'loss_factor' or 'structural_damping', not both")
            if not _is_number(table["loss_factor"]):
                raise ModelFileError(f"{where}: 'loss_factor' must be a number ≥ 0, got {table['loss_factor']!r}")
            structural = float(_non_negative(table, "loss_factor", where)) * stiffness
        names = _dof_names(table, where)
        try:
            return LumpedModel(mass, stiffness, damping, structural, names)
        except ValueError as error:
            raise ModelFileError(f"{where}: {error}") from None
    if kind == "modal":
        unknown = set(table) - MODAL_KEYS
        if unknown:
            raise ModelFileError(f"{where}: unknown key(s) {sorted(unknown)}; a modal model accepts {sorted(MODAL_KEYS)}")
        names = _dof_names(table, where)
        try:
            _require(table, "natural_frequencies_hz", where)
            return ModalModel(
                natural_frequencies_hz=_non_negative(table, "natural_frequencies_hz", where),
                mode_shapes=_numbers(_require(table, "mode_shapes", where), "mode_shapes", where,
                                     "a matrix of numbers (one row per dof, one column per mode)"),
                damping_ratios=_non_negative(table, "damping_ratios", where),
                loss_factors=_non_negative(table, "loss_factors", where),
                dof_names=names,
            )
        except ValueError as error:
            raise ModelFileError(f"{where}: {error}") from None
    raise ModelFileError(f"{where}: kind must be \"lumped\" or \"modal\", got {kind!r}")


def element_from_table(table: Mapping[str, Any], model: LumpedModel | ModalModel, where: str):
    """Build one nonlinear element from a ``[[nonlinear]]`` table."""
    kind = _require(table, "type", where)
    if kind not in ELEMENT_TYPES:
        raise ModelFileError(f"{where}: unknown type {kind!r}; expected one of {sorted(ELEMENT_TYPES)}")
    parameters = ELEMENT_TYPES[kind].parameters
    allowed = {p.name for p in parameters} | {"type", "dofs"}
    unknown = set(table) - allowed
    if unknown:
        raise ModelFileError(f"{where}: unknown key(s) {sorted(unknown)} for a {kind} element; expected {sorted(allowed)}")
    dofs = _require(table, "dofs", where)
    if not isinstance(dofs, list) or len(dofs) not in (1, 2):
        raise ModelFileError(f"{where}: 'dofs' must be a list of one dof (to ground) or two dofs, got {dofs!r}")
    try:
        indices = tuple(dof_index(model, d) for d in dofs)
    except ValueError as error:
        raise ModelFileError(f"{where}: {error}") from None
    values = {}
    for parameter in parameters:
        key = parameter.name
        if key in table:
            if parameter.sequence:
                values[key] = tuple(_numbers(table[key], key, where, "a list of numbers (highest order first)"))
            elif not _is_number(table[key]):
                raise ModelFileError(f"{where}: '{key}' must be a number (SI units), got {table[key]!r} "
                                     f"({type(table[key]).__name__}) — write numbers without quotes, e.g. 1e10")
            else:
                values[key] = table[key]
        elif not parameter.optional:
            raise ModelFileError(f"{where}: missing key '{key}' for a {kind} element")
    _check_stiffness_scale(values, parameters, model, where)
    try:
        return ELEMENT_TYPES[kind](indices, **values)
    except (TypeError, ValueError) as error:
        raise ModelFileError(f"{where}: {error}") from None


#: an element stiffness (N/m) above this multiple of the lumped model's largest stiffness is
#: refused: the solves would keep no significant digit of the structure's own stiffness
MAX_STIFFNESS_RATIO = 1e12


def _check_stiffness_scale(values: Mapping[str, Any], parameters, model, where: str) -> None:
    """Refuse an element stiffness in N/m (kt, kf, kc) more than :data:`MAX_STIFFNESS_RATIO`
    times the lumped model's largest diagonal stiffness: double precision keeps ~16
    digits, so the solver fails on such a model and would blame the frequency band."""
    if not isinstance(model, LumpedModel):
        return
    diagonal = model.stiffness.diagonal() if hasattr(model.stiffness, "diagonal") else np.diag(model.stiffness)
    scale = float(np.max(np.abs(diagonal))) if np.size(diagonal) else 0.0
    if not scale > 0:
        return
    for parameter in parameters:
        value = values.get(parameter.name)
        if parameter.unit == "N/m" and isinstance(value, (int, float)) and value > MAX_STIFFNESS_RATIO * scale:
            raise ModelFileError(
                f"{where}: '{parameter.name}' = {value:g} N/m is {value / scale:.2g} times the model's largest "
                f"stiffness ({scale:g} N/m); expected at most {MAX_STIFFNESS_RATIO:g} times it (double precision "
                f"keeps about 16 digits: the structure's own stiffness would be lost in the solves)")


def system_from_dict(data: Mapping[str, Any], source: str = "<model>") -> NonlinearSystem:
    """Nonlinear system from parsed TOML data; ``source`` names the file in errors."""
    unknown = set(data) - {"model", "nonlinear"}
    if unknown:
        raise ModelFileError(f"{source}: unknown top-level table(s) {sorted(unknown)}; expected [model] and [[nonlinear]]")
    model = linear_model_from_table(_require(data, "model", source), f"{source} [model]")
    elements = data.get("nonlinear", [])
    if not isinstance(elements, list):
        raise ModelFileError(f"{source}: 'nonlinear' must be an array of tables ([[nonlinear]])")
    built = tuple(element_from_table(t, model, f"{source} [[nonlinear]] #{i + 1}") for i, t in enumerate(elements))
    return NonlinearSystem(model, built)


def load_system(path: str | Path) -> NonlinearSystem:
    """Read a TOML model file (see module docstring)."""
    path = Path(path)
    data = parse_toml(read_input_text(path, "model file"), path, ModelFileError)
    return system_from_dict(data, str(path))


def _number(value: float) -> str:
    """A float as TOML (shortest round-trip repr; ``inf``/``nan`` are TOML too)."""
    return repr(float(value))


def _row(values) -> str:
    return "[" + ", ".join(_number(v) for v in np.ravel(values)) + "]"


def _matrix_text(matrix) -> str:
    dense = matrix.toarray() if scipy.sparse.issparse(matrix) else np.asarray(matrix, dtype=float)
    return "[" + ", ".join(_row(row) for row in dense) + "]"


def _names(names) -> str:
    return "[" + ", ".join(json.dumps(str(name)) for name in names) + "]"


def system_to_toml(system: NonlinearSystem) -> str:
    """TOML text of ``system`` that :func:`load_system` reads back to the same model."""
    model = system.model
    lines = ["[model]"]
    if isinstance(model, LumpedModel):
        lines += ['kind = "lumped"', f"mass = {_matrix_text(model.mass)}", f"stiffness = {_matrix_text(model.stiffness)}"]
        if model.damping is not None:
            lines.append(f"damping = {_matrix_text(model.damping)}")
        if model.structural_damping is not None:
            lines.append(f"structural_damping = {_matrix_text(model.structural_damping)}")
    elif isinstance(model, ModalModel):
        lines += [
            'kind = "modal"',
            f"natural_frequencies_hz = {_row(model.natural_frequencies_hz)}",
            f"mode_shapes = {_matrix_text(model.mode_shapes)}",
            f"damping_ratios = {_row(model.damping_ratios)}",
            f"loss_factors = {_row(model.loss_factors)}",
        ]
    else:
        raise ModelFileError(f"cannot write a {type(model).__name__} as a model file (lumped or modal only)")
    lines.append(f"dof_names = {_names(model.dof_names)}")
    for element in system.elements:
        kind = getattr(type(element), "type_name", None)
        if ELEMENT_TYPES.get(kind) is not type(element):
            raise ModelFileError(f"cannot write a {type(element).__name__} element: no model-file type")
        lines += ["", "[[nonlinear]]", f'type = "{kind}"', f"dofs = {list(element.dofs)}"]
        for parameter in element.parameters:
            key, value = parameter.name, getattr(element, parameter.name)
            text = _row(value) if parameter.sequence else str(value) if isinstance(value, int) else _number(value)
            lines.append(f"{key} = {text}")
    return "\n".join(lines) + "\n"


def write_system(system: NonlinearSystem, path: str | os.PathLike) -> Path:
    """Write ``system`` as a TOML model file (atomically) and return the path."""
    path = Path(path)
    with atomic_file(path) as temporary:
        Path(temporary).write_text(system_to_toml(system))
    return path
