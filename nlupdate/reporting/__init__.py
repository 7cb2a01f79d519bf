"""What a person reads: atomic output folders, plots, run archives and reports.

* :mod:`~nlupdate.reporting.atomic` — output folders built in a temporary sibling and renamed;
* :mod:`~nlupdate.reporting.plots` — FRF plots.
"""
