"""nlupdate: model updating of nonlinear structures from vibration tests.

The numerics in this package are pure functions on plain inputs (no Prefect);
``nlupdate.tasks`` and ``nlupdate.flows`` wrap them for orchestration.
"""
__version__ = "0.1.0"
