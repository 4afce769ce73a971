"""The bottom layer of geardyn: atomic file writes (:mod:`core.files`), the unit table
of scene files (:mod:`core.units`) and the base of input errors (:mod:`core.errors`).

Imports nothing of the project and nothing beyond the standard library, so that every
other package (``hbm`` excepted, which stays free of the project) may import it.
"""
