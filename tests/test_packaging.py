"""Packaging: pytest is not a runtime dependency (the plugin entry point is loaded by pytest itself);
hypothesis is, with the reason written next to it; the docs tell a clone to install `.[marl]`."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

from agspec.cli.main import COMMANDS

ROOT = Path(__file__).resolve().parent.parent


def _requirement_names(reqs):
    return {r.split(">")[0].split("=")[0].split("[")[0].strip().lower() for r in reqs}


def test_pytest_is_only_in_the_test_extra_and_hypothesis_says_why():
    text = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    project = tomllib.loads(text)["project"]
    runtime = _requirement_names(project["dependencies"])
    assert "pytest" not in runtime and "hypothesis" in runtime
    assert "pytest" in _requirement_names(project["optional-dependencies"]["test"])
    before = text[:text.index('"hypothesis>=')]
    assert "agspec diff" in before.rsplit("]", 1)[-1].rsplit("dependencies = [", 1)[-1]


def test_every_command_module_imports_without_pytest():
    """With pytest made unimportable, the CLI and every command module still load."""
    modules = sorted({target.split(":")[0] for target in COMMANDS.values()})
    code = ("import sys; sys.modules['pytest'] = None\n"
            + "".join(f"import {m}\n" for m in modules)
            + "from agspec.cli.main import main\nmain(['--help'])\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr


def test_docs_install_extras_from_the_clone():
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        text = path.read_text(encoding="utf-8")
        assert "pip install 'agspec[" not in text, path
