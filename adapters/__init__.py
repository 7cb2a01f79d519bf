"""FE adapters: every FE code behind one small interface (:class:`FEAdapter`)."""
from nlupdate.adapters.base import AdapterError, FEAdapter, ModalResult, Parameter, parameter_key

__all__ = ["AdapterError", "FEAdapter", "ModalResult", "Parameter", "parameter_key"]
