"""Markdown building blocks of the reports: numbers to a few significant digits, tables."""
from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd


def number(value: float, digits: int = 4) -> str:
    """``value`` to ``digits`` significant digits; "–" when missing or not finite."""
    if value is None or not np.isfinite(value):
        return "–"
    return f"{value:.{digits}g}"


def markdown_table(frame: pd.DataFrame, digits: int = 4) -> str:
    """A markdown table of ``frame`` (numbers to ``digits`` significant digits)."""
    def cell(value: Any) -> str:
        if isinstance(value, (float, np.floating)):
            return number(float(value), digits)
        return str(value).replace("|", "/")
    header = "| " + " | ".join(str(c).replace("|", "/") for c in frame.columns) + " |"
    rule = "|" + "---|" * len(frame.columns)
    rows = ["| " + " | ".join(cell(v) for v in row) + " |" for row in frame.itertuples(index=False)]
    return "\n".join([header, rule, *rows])
