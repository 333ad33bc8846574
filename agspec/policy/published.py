"""The paper's published rows (F-POLICY-PUBLISHED): shown beside a user's policy, never re-run.

``published.json`` holds the held-out final-test means and intervals of the MARL references (IPPO,
MAPPO, QMIX; final checkpoint) and of the non-learning references, each with the table or figure of
the paper it was copied from.  Non-learning references are also recomputed by ``agspec evaluate``.
"""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path
from typing import Any

DATA = Path(__file__).with_name("published.json")
MARL = ("IPPO", "MAPPO", "QMIX")


@lru_cache(maxsize=1)
def published() -> dict[str, Any]:
    return json.loads(DATA.read_text(encoding="utf-8"))


def rows(metric: str, policies: tuple[str, ...] = MARL) -> list[dict[str, Any]]:
    """Published rows of ``metric`` for ``policies`` (default: the MARL references)."""
    return [r for r in published()["rows"] if r["metric"] == metric and r["policy"] in policies]


def cell(metric: str, policy: str, scenario: str) -> dict[str, Any] | None:
    return next((r for r in published()["rows"]
                 if r["metric"] == metric and r["policy"] == policy and r["scenario"] == scenario), None)
