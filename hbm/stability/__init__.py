"""Stability of periodic solutions: the verdict of a point (:mod:`.verdict`), the
monodromy of the variational equation (:mod:`.monodromy`, T.10) and its transient
amplification, the exact exponents on the elements' deflections (:mod:`.exponents`, T.9),
how a verdict holds near grazing (:mod:`.grazing`), Hill's method for reference
(:mod:`.hill`) and the worker process of the continuation (:mod:`.process`)."""

from .hill import floquet_exponents
from .verdict import KINDS, Stability, Verdict, loss_of_stability, stability

__all__ = ["KINDS", "Stability", "Verdict", "floquet_exponents", "loss_of_stability",
           "stability"]
