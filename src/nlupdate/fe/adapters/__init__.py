"""FE adapters: every FE code behind one small interface (:class:`FEAdapter`).

* :mod:`nlupdate.fe.adapters.surrogate` — built-in beam FE (T-beam, gun barrel), in process;
* :mod:`nlupdate.fe.adapters.calculix` (+ :mod:`~nlupdate.fe.adapters.calculix_tbeam`) — CalculiX ``ccx`` in batch;
* :mod:`nlupdate.fe.adapters.mapdl` — ANSYS MAPDL in batch on a user's parametric APDL deck
  (its deck rules and units in ``mapdl_deck``, the generated block and table in ``mapdl_block``,
  the run's files and errors in ``mapdl_files``);
* :mod:`nlupdate.fe.adapters.runner` — the process runner both external adapters share.
"""
from nlupdate.fe.adapters.base import AdapterError, FEAdapter, ModalResult, Parameter, parameter_key

__all__ = ["AdapterError", "FEAdapter", "ModalResult", "Parameter", "parameter_key"]
