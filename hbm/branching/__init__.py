"""Branch switching at period doubling (docs/theory.md §15, docs/hbm.md "Period
doubling"): the doubled problem (:mod:`~hbm.branching.doubling`), the located period
doubling and the first point of the period-2 branch (:mod:`~hbm.branching.switching`),
and the secondary branches traced to a set depth (:mod:`~hbm.branching.cascade`)."""

from .cascade import SecondaryBranch, period_doubling_branches, trace_secondary
from .doubling import doubled_problem, doubled_set, embed, odd_mask
from .switching import (
    DoublingPoint,
    SwitchedPoint,
    doubling_brackets,
    locate_doubling,
    odd_jacobian,
    switch_branch,
)

__all__ = ["DoublingPoint", "SecondaryBranch", "SwitchedPoint", "doubled_problem",
           "doubled_set", "doubling_brackets", "embed", "locate_doubling", "odd_jacobian",
           "odd_mask", "period_doubling_branches", "switch_branch", "trace_secondary"]
