"""Safe, re-entrant initialisation of the gmsh library."""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Iterator

import gmsh

log = logging.getLogger(__name__)

_state = {"depth": 0, "owner": False}


def gmsh_initialized() -> bool:
    """True if gmsh was initialised through this module and not finalised since.

    gmsh 4.8 offers no query for its own state; if you call ``gmsh.initialize``
    yourself, do not wrap it in :func:`gmsh_session` (which would finalise it).
    """
    return bool(_state["owner"])


def ensure_initialized(verbose: bool = False) -> None:
    """Initialise gmsh if needed (it stays initialised; see :func:`gmsh_session`)."""
    if not gmsh_initialized():
        gmsh.initialize(readConfigFiles=False)
        _state["owner"] = True
        log.debug("gmsh initialised")
    gmsh.option.setNumber("General.Terminal", 1 if verbose else 0)
    gmsh.option.setNumber("General.Verbosity", 5 if verbose else 2)


def new_model(name: str) -> None:
    """Make ``name`` the current gmsh model, empty (an existing one is replaced)."""
    if name in gmsh.model.list():
        gmsh.model.setCurrent(name)
        gmsh.model.remove()
    gmsh.model.add(name)
    gmsh.model.setCurrent(name)


def finalize_gmsh() -> None:
    """Finalise gmsh if it was initialised through this module (outside a session)."""
    if _state["owner"] and _state["depth"] == 0:
        gmsh.finalize()
        _state["owner"] = False


@contextlib.contextmanager
def gmsh_session(verbose: bool = False) -> Iterator[None]:
    """Context manager that initialises gmsh and finalises it on exit.

    Re-entrant: nested sessions share one gmsh instance and only the outermost
    one that initialised gmsh finalises it. If gmsh was already initialised by
    the caller outside any session, it is left initialised.

    Parameters
    ----------
    verbose : bool
        Let gmsh print to the terminal (``General.Terminal 1``).
    """
    finalize_on_exit = False
    if not gmsh_initialized():
        gmsh.initialize(readConfigFiles=False)
        _state["owner"] = True
        finalize_on_exit = True
    gmsh.option.setNumber("General.Terminal", 1 if verbose else 0)
    gmsh.option.setNumber("General.Verbosity", 5 if verbose else 2)
    _state["depth"] += 1
    try:
        yield
    finally:
        _state["depth"] -= 1
        if finalize_on_exit:
            gmsh.finalize()
            _state["owner"] = False
            log.debug("gmsh finalised")
