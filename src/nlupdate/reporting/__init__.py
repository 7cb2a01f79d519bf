"""What a person reads: run archives, reports, tables and plots.

* :mod:`~nlupdate.reporting.archive` — one folder per run (manifest, tables, plots, report);
* :mod:`~nlupdate.reporting.report` — ``report.md``, read top to bottom;
* :mod:`~nlupdate.reporting.plots` — FRF, prediction and correlation plots.

Folders and files are written atomically by :mod:`nlupdate.files`.
"""
