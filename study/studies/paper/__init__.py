"""The comparison of a run with the paper's Sect. 4 (``paper.md``, written by
``geardyn excitations``): the reproduction of the paper, not part of the product's core.
"""
