"""The README's first screen: what a good number looks like (its command is run by test_docs' slow
part, which checks the two figures), a picture of the viewer that exists and stays small, and where
`evaluate --paper` writes (F-CLI-GRAMMAR: ./paper-reproduction, never the project's docs/)."""

from __future__ import annotations

import re
from pathlib import Path

from agspec.cli.run_cmds import PAPER_DIR

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")
FIRST_SCREEN = README[:README.index("\n## Tests")]


def test_first_screen_points_at_a_good_number():
    assert "agspec evaluate --scenario coalition-medium --indices 1000-1009" in FIRST_SCREEN
    assert re.search(r"Greedy\s+│\s+10 │\s+15\.10 ±", FIRST_SCREEN) and re.search(r"Random masked\s+│\s+10 │\s+1\.60 ±", FIRST_SCREEN)
    assert "Greedy delivers 15.1, Random masked 1.6" in FIRST_SCREEN


def test_first_screen_shows_the_viewer_in_a_small_committed_png():
    images = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", FIRST_SCREEN)
    assert images, "no picture on the README's first screen"
    for src in images:
        path = ROOT / src
        assert src.startswith("docs/img/") and path.is_file(), src
        data = path.read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) < 200_000, (src, len(data))


def test_readme_says_where_evaluate_paper_writes():
    section = README[README.index("## Reproduction of the paper"):]
    section = section[:section.index("\n## ", 3)]
    assert f"./{PAPER_DIR}/reproduction.md" in section
    assert not re.search(r"writes \[?`docs/reproduction\.md`", section)  # the committed copy, not the default output
