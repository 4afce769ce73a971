"""The frequency range a scene excites, and the ROM settings it resolves to.

:func:`highest_excitation_hz` is the top of the range (the highest excited mesh
harmonic or shaft order at the top speed); the ROM of an FE scene must be valid up to
it (the ``rom_validity`` check of :mod:`study.outputs.checks`). :func:`resolve_rom`
fills the ``[rom]`` defaults that depend on it: without ``n_cm`` and ``cutoff_Hz`` every
fixed-interface mode below ``cutoff_factor`` times that frequency is kept, and the
Fig. 9 check compares every coupled mode up to it (``check_hz``). The default factor 3 is
above the usual rule of thumb of component-mode synthesis (component modes up to 1.5–2
times the highest frequency of interest), which gives frequency errors of a few 1e-3:
the check's 1e-3 needed 3 on the spring chain of the tests and the demo gearbox
(measured convergence in docs/reduction.md, "Choosing the component modes").
"""
from __future__ import annotations

import dataclasses

__all__ = ["excited_harmonics", "highest_excitation_hz", "resolve_rom"]


def excited_harmonics(ms, te) -> int:
    """Mesh harmonics excited by a mesh stiffness and a TE series (at least 1)."""
    return max(len(ms.amplitudes) if ms is not None else 0,
               len(te.amplitudes) if te is not None else 0, 1)


def highest_excitation_hz(scene) -> tuple[float, str]:
    """(Hz, label) of the highest excitation frequency of the run: the highest excited
    mesh harmonic k·Z (k up to the number of mesh-stiffness or TE harmonics; in a gear
    train, of each mesh at its mesh frequency) or external shaft order (in a train, order
    k of shaft s at k times that shaft's speed: ``[[external.aero]]`` orders and the
    unbalances' order 1), at the top speed of the range (the drive shaft's)."""
    top = scene.continuation.speed[1]
    if getattr(scene, "is_train", False):
        from machines import machine_for

        layout = machine_for(scene).layout
        best = (0.0, "")
        for m, md in zip(layout.meshes, scene.meshes, strict=True):
            k = excited_harmonics(md.mesh_stiffness, md.transmission_error)
            order = k * float(m.frequency_ratio)
            if order > best[0]:
                best = (order, f"{k} × the mesh frequency of `{md.name}`")
        for (shaft, k), ratio in layout.order_frequencies().items():
            if float(ratio) > best[0]:
                best = (float(ratio), f"order {k} of shaft `{shaft}`")
        return best[0] * top / 60.0, f"{best[1]} at {top:g} rpm"
    z = scene.gear.teeth
    k = excited_harmonics(scene.mesh_stiffness, scene.transmission_error)
    order, label = k * z, f"{k} Z" if k > 1 else "Z"
    ext = max(scene.external.orders, default=0)
    if ext > order:
        order, label = ext, f"shaft order {ext}"
    return order * top / 60.0, f"{label} at {top:g} rpm"


def resolve_rom(scene):
    """``scene`` with its ``[rom]`` range filled in: ``check_hz`` the highest excitation
    frequency, and without ``n_cm`` and ``cutoff_Hz`` the cut-off ``cutoff_factor ×
    check_hz`` (Hz); the scene itself when it has no FE machine to reduce."""
    from machines import FEMachine, machine_for

    if not isinstance(machine_for(scene), FEMachine):
        return scene
    f_exc, _ = highest_excitation_hz(scene)
    r = scene.rom
    auto = r.n_cm is None and r.cutoff is None
    cutoff = r.cutoff_factor * f_exc if auto else r.cutoff
    return dataclasses.replace(scene, rom=dataclasses.replace(r, cutoff=cutoff, auto=auto,
                                                              check_hz=f_exc))
