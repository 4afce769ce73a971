"""The convergence study (``geardyn convergence``, docs/convergence.md).

:mod:`~study.studies.convergence.knobs` (one :class:`Knob` entry per numerical knob) →
:mod:`~study.studies.convergence.measures` (error measures, :class:`Row`, the
recommendation) → :mod:`~study.studies.convergence.report` (``convergence.csv``,
``convergence.md``, ``pareto.png``) → :mod:`~study.studies.convergence.sweep`
(:func:`run_convergence`: one knob at a time through the cached pipeline).
"""
