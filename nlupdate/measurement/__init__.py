"""Measured data: FRF and modal tables, the files tests deliver, noise.

* :mod:`~nlupdate.measurement.frf_table` — what a measured-FRF table is: validation, building, selecting curves;
* :mod:`~nlupdate.measurement.frf_files` — reading and writing them (parquet, CSV, UFF 58, MATLAB);
* :mod:`~nlupdate.measurement.uff` — UFF 58 FRFs as test systems export them;
* :mod:`~nlupdate.measurement.matfile` — MATLAB v5 / v7.3 files;
* :mod:`~nlupdate.measurement.units` — force or voltage reference, calibration, units per volt;
* :mod:`~nlupdate.measurement.time_history` — time histories to first-harmonic FRFs (``nlupdate frf``);
* :mod:`~nlupdate.measurement.band` — the excited band of a measured FRF;
* :mod:`~nlupdate.measurement.coherence` — noise level of an H1 estimate from coherence;
* :mod:`~nlupdate.measurement.modal_table` — natural frequency and damping per mode and level;
* :mod:`~nlupdate.measurement.noise` — docs/methods.md §8 noise on simulated FRFs.
"""
