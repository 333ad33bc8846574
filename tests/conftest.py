"""Test-session settings shared by every test module."""

from __future__ import annotations

import os


def pytest_configure(config) -> None:
    # F-GOLDEN: conform runs in tests are live unless a test names its own cache directory — a
    # user's cache (~/.cache/agspec/golden) must neither speed up nor change what a test observes
    os.environ["AGSPEC_GOLDEN_CACHE"] = "off"
    # F-SCHEMAS-SELF: every document agspec writes in any test — report lines, traces, golden files,
    # reproducers, results bundles, the lock, check reports, every `--format json` output — is
    # validated against its schema as it is written (in this process and in every agspec process a
    # test starts), and a violation fails the test (SchemaDrift), so no field or category drifts
    os.environ["AGSPEC_SELF_CHECK"] = "1"
