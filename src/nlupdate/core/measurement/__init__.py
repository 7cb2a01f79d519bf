"""Measured data: FRF and modal tables, the files tests deliver, noise.

* :mod:`~nlupdate.core.measurement.frf_table` — what a measured-FRF table is: validation, building, selecting curves;
* :mod:`~nlupdate.core.measurement.frf_files` — reading and writing them (parquet, CSV, UFF 58, MATLAB);
* :mod:`~nlupdate.core.measurement.uff` — UFF 58 FRFs as test systems export them;
* :mod:`~nlupdate.core.measurement.matfile` — MATLAB v5 / v7.3 files;
* :mod:`~nlupdate.core.measurement.units` — force or voltage reference, calibration, units per volt;
* :mod:`~nlupdate.core.measurement.time_history` — time histories to first-harmonic FRFs (``nlupdate frf``);
* :mod:`~nlupdate.core.measurement.band` — the excited band of a measured FRF;
* :mod:`~nlupdate.core.measurement.coherence` — noise level of an H1 estimate from coherence;
* :mod:`~nlupdate.core.measurement.modal_table` — natural frequency and damping per mode and level;
* :mod:`~nlupdate.core.measurement.noise` — docs/methods.md §8 noise on simulated FRFs.
"""
