"""S-FEASIBILITY 7 (AG459): a scenario whose products can be heavier than the robots' payload is
refused at validate time — such a product can never be handed off (R-HANDOFF), so it is never delivered."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from agspec.cli.main import cli

ROOT = Path(__file__).resolve().parent.parent


def _scenario(tmp_path: Path, mass: str) -> Path:
    text = (ROOT / "catalogue" / "scenarios" / "flow-easy.ag").read_text(encoding="utf-8")
    lines = [ln for ln in text.splitlines() if not ln.startswith("use ")]
    path = tmp_path / "s.ag"
    path.write_text("\n".join(lines).replace("mass 0.5..2.0", f"mass {mass}") + "\n", encoding="utf-8")
    return path


@pytest.mark.parametrize("mass, refused", [("11.0..12.0", True), ("0.5..12.0", True), ("0.5..10.0", False)])
def test_products_heavier_than_the_payload_are_refused(tmp_path, mass, refused):
    res = CliRunner().invoke(cli, ["validate", str(_scenario(tmp_path, mass))])
    assert ("error[AG459]" in res.stderr) is refused
    assert res.exit_code == (1 if refused else 0), res.stderr
    if refused:
        assert "s.ag:18:14:" in res.stderr and "payload 10.0" in res.stderr  # at `products mass`, in DSL words
