"""The house: floors that run one way, no import circle, no borrowed private names, no stale module names
(the checks are in tests/architecture_guard.py; the floors are the table of docs/architecture.md).

Each check runs on the repository and, to prove it can fail, on a copy with a planted fault.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

import architecture_guard as A

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def copy_root(tmp_path: Path) -> Path:
    """The parts the checks read: the package, the floors table and the test modules (not their data)."""
    shutil.copytree(ROOT / "agspec", tmp_path / "agspec", ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    for part in ("docs", "tests", "benchmarks", "spec"):
        (tmp_path / part).mkdir()
        for path in (ROOT / part).glob("*.*"):
            if path.suffix in (".py", ".md"):
                shutil.copy(path, tmp_path / part / path.name)
    shutil.copy(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    return tmp_path


def _append(path: Path, text: str) -> None:
    path.write_text(path.read_text(encoding="utf-8") + text, encoding="utf-8")


def test_every_part_of_the_package_stands_on_a_floor():
    assert A.unplaced(ROOT) == []
    assert set(A.floors(ROOT).values()) == set(range(12))


def test_no_import_runs_up_or_sideways():
    assert A.upward(ROOT) == []


def test_no_import_circle_between_modules():
    assert A.circles(ROOT) == []


def test_no_import_of_another_parts_private_name():
    assert A.private_names(ROOT) == []


def test_every_dotted_module_name_exists():
    assert A.stale_module_names(ROOT) == []


def test_a_planted_upward_lazy_import_is_reported(copy_root):
    _append(copy_root / "agspec" / "interp" / "rules.py", "\n\ndef _late():\n    from agspec.conform import runner\n")
    assert any(r.startswith("agspec.interp.rules") and "agspec.conform.runner" in r for r in A.upward(copy_root))


def test_a_planted_circle_is_reported(copy_root):
    _append(copy_root / "agspec" / "policy" / "stats.py", "\n\ndef _late():\n    from agspec.policy import tables\n")
    assert any("agspec.policy.stats" in c and "agspec.policy.tables" in c for c in A.circles(copy_root))


def test_a_planted_private_import_is_reported(copy_root):
    _append(copy_root / "agspec" / "trace" / "verify.py", "\nfrom agspec.interp.metrics import _helper  # noqa\n")
    assert any("takes _helper" in r for r in A.private_names(copy_root))


def test_a_new_folder_must_be_placed(copy_root):
    (copy_root / "agspec" / "newpart").mkdir()
    (copy_root / "agspec" / "newpart" / "__init__.py").write_text('"""A part nobody placed."""\n')
    assert A.unplaced(copy_root) == ["newpart"]


def test_a_renamed_module_leaves_no_check_of_its_old_name(copy_root):
    """The string a test checks must still name a module: here the plugin test's module list."""
    shutil.move(copy_root / "agspec" / "conform" / "run_item.py", copy_root / "agspec" / "conform" / "item_run.py")
    assert any(r.startswith("tests/test_pytest_plugin.py") and r.endswith("agspec.conform.run_item")
               for r in A.stale_module_names(copy_root))
