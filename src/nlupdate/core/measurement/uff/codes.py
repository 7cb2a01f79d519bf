"""UFF dataset 58 codes and the fields every reader of the format decodes the same way.

The numeric codes of record 6 (function type) and records 8–11 (specific data types), the
direction codes of record 6 (0 scalar, ±1…±6 = x, y, z, rx, ry, rz, a negative sign meaning
measured along the negative axis) and the five ID lines. nlupdate's own files store exact
metadata in the ID lines as ``key=value`` (:mod:`nlupdate.core.measurement.uff.writer`); a
coordinate without such a line is named ``"<node>"`` (direction 0) or
``"<node>:<ux|uy|uz|rx|ry|rz>"``.
"""
from __future__ import annotations

from nlupdate.core.measurement.frf_table import MeasurementTableError

# function types (record 6 field 1)
TIME_RESPONSE, FRF, TRANSMISSIBILITY, COHERENCE = 1, 4, 5, 6
FUNCTION_NAMES = {0: "general", 1: "time response", 2: "auto spectrum", 3: "cross spectrum", 4: "frequency response",
                  5: "transmissibility", 6: "coherence", 7: "auto correlation", 8: "cross correlation",
                  9: "power spectral density", 10: "energy spectral density", 11: "probability density",
                  12: "spectrum"}
# specific data types (records 8-11 field 1)
UNKNOWN, GENERAL, DISPLACEMENT, REACTION, VELOCITY, ACCELERATION, FORCE, TIME_AXIS, FREQUENCY = (
    0, 1, 8, 9, 11, 12, 13, 17, 18)
DIRECTIONS = {"ux": 1, "uy": 2, "uz": 3, "rx": 4, "ry": 5, "rz": 6}
DIRECTION_NAMES = {code: name for name, code in DIRECTIONS.items()}


def field_label(dataset: dict, field: str) -> str:
    """A unit label of ``dataset`` without blanks (empty when the field is)."""
    return str(dataset.get(field, "") or "").strip().replace(" ", "")


def id_lines(dataset: dict) -> list[str]:
    """The five ID lines of ``dataset`` (an empty string for an empty one)."""
    return [str(dataset.get(f"id{n}", "") or "") for n in range(1, 6)]


def id_keys(dataset: dict) -> dict[str, str]:
    """The ``key=value`` pairs of the ID lines (nlupdate's own metadata)."""
    keys = {}
    for line in id_lines(dataset):
        key, sep, value = line.partition("=")
        if sep:
            keys[key.strip()] = value
    return keys


def id_floats(keys: dict[str, str], key: str, count: int, where: str) -> list[float]:
    """The ``count`` comma-separated numbers of the ID line ``key``; refused naming it otherwise."""
    try:
        values = [float(v) for v in keys[key].split(",")]
    except ValueError:
        values = []
    if len(values) != count:
        raise MeasurementTableError(f"{where}: ID line '{key}={keys[key]}' should hold {count} comma-separated number(s)")
    return values


def name_from_node(node: int, direction: int) -> str:
    """The coordinate name of a node and a direction, without the direction's sign."""
    if direction == 0:
        return str(node)
    if abs(direction) in DIRECTION_NAMES:
        return f"{node}:{DIRECTION_NAMES[abs(direction)]}"
    return f"{node}:{abs(direction)}"


def check_directions(dataset: dict, where: str) -> None:
    """Refuse a direction code other than 0 (scalar) and ±1…±6 (record 6 fields 7, 10)."""
    for field, what in (("rsp_dir", "response"), ("ref_dir", "reference")):
        code = dataset.get(field, 0)
        if abs(int(code)) > 6:
            raise MeasurementTableError(
                f"{where}: {what} direction code {code} (record 6); expected 0 (scalar) or ±1…±6 (x, y, z, rx, ry, rz)")

