"""The official catalogue as loaded by users: parsed from catalogue/*.ag through the DSL."""

from __future__ import annotations

import copy
from functools import lru_cache

from agspec.catalogue import load_scenario_bundle


@lru_cache(maxsize=None)
def _bundle(name: str):
    return load_scenario_bundle(name)


def official_bundle(name: str):
    """(scenario IR, recipes, profile IR) of an official scenario; a fresh copy per call."""
    return copy.deepcopy(_bundle(name))
