"""Markdown building blocks of the reports: numbers to a few significant digits, tables,
the line on the run."""
from __future__ import annotations

import datetime as dt
from typing import Any, Mapping

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


def run_line(manifest: Mapping[str, Any]) -> str:
    """The report's line on the run: its id, when it started (UTC), how long its steps took
    and how it was run. The manifest's ``run.wall_time_s`` is the wall time from the first
    step to the last, as the flows and ``nlupdate update`` measure it: writing the archive
    is not in it, nor, for a Prefect flow run (one with a ``flow_run_id``), starting the
    Prefect server; the line says so."""
    run = manifest.get("run", {})
    try:
        started = dt.datetime.fromisoformat(run["started_utc"]).astimezone(dt.timezone.utc)
        started_text = f"{started:%Y-%m-%d %H:%M:%S} UTC"
    except (KeyError, TypeError, ValueError):
        started_text = "?"
    left_out = "starting the Prefect server or writing this archive" if run.get("flow_run_id") \
        else "writing this archive"
    return (f"Run `{manifest['run_id']}`, started {started_text}; its steps took "
            f"{number(run.get('wall_time_s', float('nan')), 3)} s (wall clock; not counting {left_out}); "
            f"{run.get('orchestration', '')}.")
