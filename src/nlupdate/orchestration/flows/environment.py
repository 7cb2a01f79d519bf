"""Process environment for a run, set before Prefect or Dask start (imports nothing heavy).

* Prefect's own console logging is quiet (``PREFECT_LOGGING_LEVEL=WARNING``, and the
  console handler shows nothing below CRITICAL) unless the user chose otherwise: the
  project prints its own progress, and a failing run ends as one line from the CLI,
  while the run's warnings and errors, with tracebacks, still reach its log in the UI.
* The Prefect server never phones home (``PREFECT_SERVER_ANALYTICS_ENABLED=false``).
* Dask's INFO chatter is off, and worker processes use one BLAS thread each
  (``OPENBLAS_NUM_THREADS``/``OMP_NUM_THREADS``/``MKL_NUM_THREADS``), so N workers on N
  cores do not fight over them. Worker processes inherit this environment.
"""
from __future__ import annotations

import os

DEFAULTS = {
    "PREFECT_LOGGING_LEVEL": "WARNING",
    "PREFECT_LOGGING_HANDLERS_CONSOLE_LEVEL": "CRITICAL",
    "PREFECT_SERVER_ANALYTICS_ENABLED": "false",
    "DASK_DISTRIBUTED__LOGGING__DISTRIBUTED": "error",
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
}


def prepare_environment() -> None:
    """Set every default of :data:`DEFAULTS` the user has not set."""
    for name, value in DEFAULTS.items():
        os.environ.setdefault(name, value)
