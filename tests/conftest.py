"""Test-session settings shared by every test module."""

from __future__ import annotations

import os


def pytest_configure(config) -> None:
    # F-GOLDEN: conform runs in tests are live unless a test names its own cache directory — a
    # user's cache (~/.cache/agspec/golden) must neither speed up nor change what a test observes
    os.environ["AGSPEC_GOLDEN_CACHE"] = "off"
