"""A generator of unseen machines, errors and campaigns, written blind (issue 40).

Used only by ``benchmarks/bench_unseen.py`` and ``tests/test_generator.py``; it imports nothing
from vecpin (vecpin is called as a user calls it: the ``vecpin`` command). Modules:
``layouts`` (random layouts -> URDF), ``fields`` (Gaussian-process error functions),
``kinematics`` (the truth's forward kinematics, numpy), ``truth`` (error fields and effects),
``campaign`` (rows, tracker, noise, CSV), ``draw`` (one campaign from a seed).
"""
from .draw import draw_campaign, heldout_csv

__all__ = ["draw_campaign", "heldout_csv"]
