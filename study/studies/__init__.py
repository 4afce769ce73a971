"""Studies made of many runs of the pipeline.

:mod:`~study.studies.variants` (``--set key=v1,v2``: overlay and table),
:mod:`~study.studies.excitations` (``geardyn excitations``: the internal, external and
all excitation cases of a scene on one cached ROM), :mod:`study.studies.convergence`
(``geardyn convergence``: error against cost per numerical knob) and
:mod:`study.studies.paper` (the comparison with the paper's Sect. 4: the reproduction of
the paper, not part of the product's core).

Imports :mod:`study.scene`, :mod:`study.outputs`, :mod:`study.plots` and
:mod:`study.pipeline` (docs/architecture.md); a name is imported from the module that
holds it (these ``__init__`` files re-export nothing).
"""
