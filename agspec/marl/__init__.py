"""MARL adapters (PettingZoo, Gymnasium) over the reference interpreter; see spec/12-adapters.md.

Needs the optional extra ``agspec[marl]``; the public entry points are :mod:`agspec.pettingzoo`
and :mod:`agspec.gymnasium`.
"""
