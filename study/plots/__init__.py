"""PNG plots of a run (matplotlib, Agg backend), by what they draw.

:mod:`~study.plots.common` (the Agg backend, atomic PNG writing, impact shading) →
:mod:`~study.plots.speed` (forced response, overlay, ERP, accelerometers against speed),
:mod:`~study.plots.point` (time series and spectrum of one solution),
:mod:`~study.plots.modes` (Campbell diagram, ROM error, order maps) →
:mod:`~study.plots.figures` (:func:`~study.plots.figures.draw_all`: what the scene's
``[outputs] plots`` asks for). :mod:`~study.plots.render` renders the housing's XDMF
field with pyvista in a child process.

Imports :mod:`study.scene` and :mod:`study.outputs`, nothing above (docs/architecture.md);
a name is imported from the module that holds it (this ``__init__`` re-exports nothing).
"""
