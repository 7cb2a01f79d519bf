"""Measured FRFs in universal files (UFF dataset 58, ``.uff`` / ``.unv``), read and written with pyuff.

* :mod:`~nlupdate.core.measurement.uff.codes` — the format's codes, ID lines and direction fields;
* :mod:`~nlupdate.core.measurement.uff.fields` — what a dataset measured: ordinate, reference,
  abscissa, coordinates, excitation (the conversions to receptance per N or V);
* :mod:`~nlupdate.core.measurement.uff.levels` — the level of a dataset (the order it is looked for in);
* :mod:`~nlupdate.core.measurement.uff.reader` — files from test systems to one raw FRF table
  (runs, coherence, skipped datasets, truncated files);
* :mod:`~nlupdate.core.measurement.uff.writer` — nlupdate's own files (binary 58, exact ID-line metadata).
"""
from nlupdate.core.measurement.uff.codes import check_directions, name_from_node
from nlupdate.core.measurement.uff.reader import read_uff_frf, uff_datasets
from nlupdate.core.measurement.uff.writer import write_uff_frf

__all__ = ["check_directions", "name_from_node", "read_uff_frf", "uff_datasets", "write_uff_frf"]
