"""What the Prefect UI calls the runs of a study: flow and task-run names that say
what they are, built from plain values (names of the study, its steps and runs, parameter
values). The progress lines and the manifest use the same names, so a line of either maps
to one run on the server.

=====================  ==========================================
the study flow run     ``two-dof 2026-11-25 10:03 UTC``
a step's task run      ``identification: two-dof``
a job's task run       ``updating: eigensensitivity central O(h²) {E, h2}``,
                       ``prediction: optimisation {E, h2} equal weights``
a discovery candidate  ``candidate fit, round 2: dry_friction on [0]``
=====================  ==========================================

Names are written in ASCII (:func:`ascii_name`): the UI's run graph draws labels with a
bitmap font of the ASCII characters only and drops the others, so ``central O(h²)`` and
``central O(h⁴)`` would both read ``central O(h)``; they are ``O(h^2)`` and ``O(h^4)``.
"""
from __future__ import annotations

import datetime as dt
import unicodedata

#: What one job of a fan-out step is called (the step's name is plural).
JOB_NOUNS = {"updating": "updating", "predictions": "prediction"}

_SUPERSCRIPTS = str.maketrans({"⁰": "^0", "¹": "^1", "²": "^2", "³": "^3", "⁴": "^4", "⁵": "^5", "⁶": "^6",
                                "⁷": "^7", "⁸": "^8", "⁹": "^9", "⁻": "^-"})


def ascii_name(text: str) -> str:
    """``text`` as the run graph can draw it: superscripts as ``^2``, accents dropped
    (``Träger`` → ``Trager``); what has no ASCII form is kept (the run's page shows it)."""
    text = unicodedata.normalize("NFKD", text.translate(_SUPERSCRIPTS))
    return "".join(c for c in text if not unicodedata.combining(c))


def study_run_name(study: str, started: dt.datetime) -> str:
    """The study flow run: the study and when it started (UTC, to the minute)."""
    return ascii_name(f"{study} {started.astimezone(dt.timezone.utc):%Y-%m-%d %H:%M} UTC")


def step_run_name(step: str, study: str) -> str:
    """A chain step's task run: ``identification: two-dof``."""
    return ascii_name(f"{step}: {study}")


def job_run_name(step: str, job: str) -> str:
    """One job of a fan-out step, by its own name: ``updating: central O(h^2) {E}``. Also
    its key in the progress lines and the manifest."""
    return ascii_name(f"{JOB_NOUNS.get(step, step)}: {job}")


def candidate_fit_name(round_number: int, effect: str, dofs) -> str:
    """A discovery candidate fit: ``candidate fit, round 2: dry_friction on [0]``."""
    return ascii_name(f"candidate fit, round {round_number}: {effect} on {list(dofs)}")
