"""Measured data: FRF tables (parquet, CSV, UFF58) and the measurement-noise model.

* :mod:`~nlupdate.measurement.frf_table` — validation, selection and file I/O of FRF tables;
* :mod:`~nlupdate.measurement.noise` — METHODS §8 noise on simulated FRFs.
"""
