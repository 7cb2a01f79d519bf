"""The front doors: the command line (:mod:`~nlupdate.app.cli`) and the Python API
(:mod:`~nlupdate.app.api`, re-exported as ``nlupdate.*``). Top layer: imports every layer
below, none imports it.
"""
