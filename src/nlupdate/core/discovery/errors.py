"""Errors of the discovery workflow: one line each, naming what to fix.

All are :class:`ValueError` subclasses so the CLI prints them as
``nlupdate discover: error: …`` and exits 2.
"""
from __future__ import annotations


class DiscoveryError(ValueError):
    """Discovery cannot run on these inputs (the message says why)."""


class MeasuredDataError(DiscoveryError):
    """The measured table cannot be used (names the table, column or coordinate)."""


class ModelSolveError(DiscoveryError):
    """The model cannot be solved at a measured force level and frequency."""


class UnphysicalModelError(DiscoveryError):
    """A candidate's linear correction leaves the model without a positive stiffness in some
    mode: a finding about that candidate, which the search rejects (with this message as the
    reason) rather than a fault of the inputs."""
