"""The benchmarks' baseline side runs the baseline release, never this build.

A ratio against a baseline is only a figure if the baseline is another build.  Started as
``python -c`` from the checkout, a Python puts the working directory first on its module path and
imports the checkout's agspec whatever environment it belongs to; the baseline's CLI is therefore
started with ``-P`` (:func:`_common.baseline_cli`), and a baseline Python whose agspec has this
build's sources is refused (:func:`_common.baseline_python`).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import _common  # noqa: E402  (the benchmarks' helper module, by path)

WHERE = "import agspec; print(agspec.__file__)"


@pytest.fixture
def other_build(tmp_path: Path) -> tuple[Path, dict[str, str]]:
    """A stand-in baseline: an agspec package of other sources, on the module path via PYTHONPATH."""
    package = tmp_path / "site" / "agspec"
    package.mkdir(parents=True)
    (package / "__init__.py").write_text("BASELINE = True\n")
    return package, {**os.environ, "PYTHONPATH": str(package.parent)}


def _imported(cmd: list[str], env: dict[str, str]) -> Path:
    proc = subprocess.run([*cmd, "-c", WHERE], cwd=ROOT, env=env, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    return Path(proc.stdout.strip()).resolve().parent


def test_python_c_from_the_checkout_imports_the_checkout(other_build):
    """The pitfall itself: with ``-c`` the working directory comes before the environment's path."""
    _, env = other_build
    assert _imported([sys.executable], env) == ROOT / "agspec"


def test_the_baseline_cli_imports_the_baseline(other_build):
    package, env = other_build
    assert _common.baseline_cli(sys.executable)[1] == "-P"
    assert _imported(_common.baseline_cli(sys.executable)[:2], env) == package.resolve()


def test_a_baseline_with_this_builds_sources_is_refused():
    # this interpreter imports this build (the checkout, or an install of it)
    with pytest.raises(SystemExit, match="this build's sources"):
        _common.baseline_python(sys.executable)


def test_a_baseline_with_other_sources_is_accepted(other_build, tmp_path: Path):
    _, env = other_build
    wrapper = tmp_path / "python"
    wrapper.write_text(f"#!/bin/sh\nPYTHONPATH={env['PYTHONPATH']} exec {sys.executable} \"$@\"\n")
    wrapper.chmod(0o755)
    assert _common.baseline_python(str(wrapper)) == str(wrapper)


def test_a_missing_baseline_python_is_a_clear_error(tmp_path: Path):
    with pytest.raises(SystemExit, match="does not exist"):
        _common.baseline_python(str(tmp_path / "nope" / "python"))
