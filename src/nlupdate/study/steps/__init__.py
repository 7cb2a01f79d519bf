"""The steps of a study, each a function of plain inputs (a :class:`~nlupdate.study.spec.Study`
and what earlier steps returned); :mod:`nlupdate.study.chain` declares their order.

Both interpreters of the chain — :func:`nlupdate.study.sequential.run_study` in one process and
the Prefect flows (:mod:`nlupdate.orchestration.flows`) as cached tasks — call these very functions;
nothing here knows which of the two is calling, nor where FE points are evaluated (the
fan-out steps get an evaluator).

measured data → identification → targets → updating runs (one per formula × parameter
set and per optimisation candidate) → comparison, ranking and parameter uncertainty →
the candidates' linear FRFs → predictions of the updated nonlinear models at every force
level, correlated → validation on held-out levels → the warnings on results not to be
trusted as they stand. One module per part:

* :mod:`~nlupdate.study.steps.measured` — the measured data, the identification, and the
  measured curve's coordinates (measured and in the FE model);
* :mod:`~nlupdate.study.steps.updating` — targets, updating runs, their comparison and the
  candidates' linear FRFs;
* :mod:`~nlupdate.study.steps.prediction` — the updated nonlinear models' predictions;
* :mod:`~nlupdate.study.steps.validation` — ``[validation]`` on held-out levels;
* :mod:`~nlupdate.study.steps.trust` — the warnings on the results;
* :mod:`~nlupdate.study.steps.record` — the FE models the study used, for the archive.
"""
