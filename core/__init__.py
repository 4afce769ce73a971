"""The bottom layer of geardyn: atomic file writes (:mod:`core.files`), the unit table
of scene files (:mod:`core.units`), the base of input errors (:mod:`core.errors`) and
independent per-item work shared with forked processes (:mod:`core.processes`).

Imports nothing of the project and nothing beyond the standard library, so that every
other package (``hbm`` excepted, which stays free of the project) may import it.
"""
