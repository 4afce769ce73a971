"""What a run hands to the user: files and the branch queries they are made of.

``results.h5`` (:mod:`~study.outputs.results`), ``report.md``
(:mod:`~study.outputs.report`), the noise and vibration views and ``curves.csv``
(:mod:`~study.outputs.nvh`, the levels and the equivalent radiated power of
:mod:`~study.outputs.acoustics`), the features of a forced-response curve
(:mod:`~study.outputs.curves`), points of a branch (:mod:`~study.outputs.points`), the
time responses at unstable segments (:mod:`~study.outputs.attractors`), the housing
fields and virtual accelerometers from the cached arrays of :mod:`fem.post`
(:mod:`~study.outputs.fields`) and the housing field error of the convergence study
(:mod:`~study.outputs.housing_error`).

Imports :mod:`study.scene` and nothing else of :mod:`study` (docs/architecture.md);
a name is imported from the module that holds it (this ``__init__`` re-exports nothing).
"""
