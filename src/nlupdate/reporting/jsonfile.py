"""JSON files a person can read and any JSON parser can load (no NaN, no numpy types)."""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np


def json_safe(value: Any) -> Any:
    """JSON-safe copy: numpy scalars and arrays to Python, NaN/inf to None, tuples to lists."""
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [json_safe(v) for v in value]
    if isinstance(value, (np.floating, float)):
        return float(value) if math.isfinite(float(value)) else None
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, complex):
        return {"real": json_safe(value.real), "imag": json_safe(value.imag)}
    return value


def write_json(data: Any, path: str | Path) -> Path:
    """Write ``data`` (made JSON-safe) with indentation and a final newline."""
    path = Path(path)
    path.write_text(json.dumps(json_safe(data), indent=2, allow_nan=False) + "\n")
    return path
