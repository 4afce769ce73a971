"""The comparison of a run with the paper's Sect. 4 (``paper.md``, written by ``geardyn
excitations``): the reproduction of the paper, not part of the product's core.

:mod:`~study.studies.paper.findings` (the paper's findings, each with its section and
figure) → :mod:`~study.studies.paper.measure` (the run's quantities beside them: the
excitation cases' curves, the solutions at the paper's speeds, their IPP sequences and
spectra, the ROM's mesh mode) → :mod:`~study.studies.paper.report` (``paper.md`` and the
time series at the paper's speeds).
"""
