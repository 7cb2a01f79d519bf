"""Process environment for a run, set before Prefect or Dask start (imports nothing heavy).

* Prefect's own console logging is quiet (``PREFECT_LOGGING_LEVEL=WARNING``, and the
  console handler shows nothing below CRITICAL) unless the user chose otherwise: the
  project prints its own progress, and a failing run ends as one line from the CLI,
  while the run's warnings and errors, with tracebacks, still reach its log in the UI.
* Neither the Prefect server nor its client phones home: ``PREFECT_SERVER_ANALYTICS_ENABLED=false``
  for the server, ``DO_NOT_TRACK=1`` for the client (Prefect ≥ 3.6 starts an SDK telemetry
  service on import in an interactive terminal, which asks the server whether to send
  usage events — to a server the user started with analytics on, it would).
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
    "DO_NOT_TRACK": "1",
    "DASK_DISTRIBUTED__LOGGING__DISTRIBUTED": "error",
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
}


def prepare_environment() -> None:
    """Set every default of :data:`DEFAULTS` the user has not set."""
    for name, value in DEFAULTS.items():
        os.environ.setdefault(name, value)
