"""Test-session settings shared by every test module."""

from __future__ import annotations

import os

import pytest

import tiers


def pytest_configure(config) -> None:
    # F-GOLDEN: conform runs in tests are live unless a test names its own cache directory — a
    # user's cache (~/.cache/agspec/golden) must neither speed up nor change what a test observes
    os.environ["AGSPEC_GOLDEN_CACHE"] = "off"
    # F-SCHEMAS-SELF: every document agspec writes in any test — report lines, traces, golden files,
    # reproducers, results bundles, the lock, check reports, every `--format json` output — is
    # validated against its schema as it is written (in this process and in every agspec process a
    # test starts), and a violation fails the test (SchemaDrift), so no field or category drifts
    os.environ["AGSPEC_SELF_CHECK"] = "1"


def pytest_collection_modifyitems(config, items) -> None:
    # the extended tier (tests/tiers.py): the tests tests/extended.txt lists
    tiers.mark(items, frozenset(entry.test for entry in tiers.entries()))
    _optional_parts(items)


def _optional_parts(items) -> None:
    """The tests that need optional parts (README, "Tests"): `ray` starts a local Ray cluster, `browser` drives Chromium.

    The README's `pytest -q` leaves them out (pyproject addopts); `.ci/run` runs them after it. A test
    is marked by what it uses, so a new one is classed without a decorator: the `browser` or
    `ray_session` fixture, or a parameter whose id names the Ray executor (`ray`, `ray-j2`).
    """
    for item in items:
        if "browser" in item.fixturenames:
            item.add_marker(pytest.mark.browser)
        callspec = getattr(item, "callspec", None)
        if "ray_session" in item.fixturenames or (callspec is not None and "ray" in callspec.id.split("-")):
            item.add_marker(pytest.mark.ray)
