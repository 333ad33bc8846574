"""Shared by the viewer's tests (test_render.py, test_viewer_layout.py): traces recorded in process,
`agspec render` through the CLI, and pages loaded in headless Chromium through Playwright (Debian's
chromium, never a downloaded browser; the `browser` fixture skips with a reason when either is
missing, and conftest marks every test that uses it `browser`)."""

from __future__ import annotations

import io
import json
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from agspec.catalogue import load_scenario_bundle
from agspec.cli.main import cli
from agspec.evaluate import run_episode
from agspec.formats.trace import TraceWriter
from agspec.ir.instance import make_instance

SIM = Path(__file__).resolve().parent / "mutants" / "sim.py"
DATA_START = '<script type="application/json" id="replay-data">'
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def record_reference(scenario: str, ticks: int, observations: bool = False, controller: str = "greedy") -> list[dict]:
    """The records of `agspec run SCENARIO --horizon TICKS --trace` (in process)."""
    sc, recipes, profile = load_scenario_bundle(scenario)
    buf = io.StringIO()
    run_episode(make_instance(sc, recipes, profile, index=0), controller, horizon=ticks, trace=TraceWriter(buf),
                observations_in_trace=observations)
    return [json.loads(line) for line in buf.getvalue().splitlines()]


def write_trace(records: list[dict], path: Path) -> Path:
    path.write_text("".join(json.dumps(r, sort_keys=True) + "\n" for r in records), encoding="utf-8")
    return path


def render(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(cli, ["render", *args])
    assert not isinstance(result.exception, Exception) or isinstance(result.exception, SystemExit), result.exception
    return result.exit_code, result.output


def embedded(page: Path) -> dict:
    text = page.read_text(encoding="utf-8")
    start = text.index(DATA_START) + len(DATA_START)
    return json.loads(text[start:text.index("</script>", start)])


@pytest.fixture(scope="module")
def failing_report(tmp_path_factory) -> Path:
    """A real report of `agspec conform` against the dup-handoff mutant (R-HANDOFF, INV-CONSERVATION)."""
    where = tmp_path_factory.mktemp("report")
    spec = shlex.join([sys.executable, str(SIM), "--mutant", "dup-handoff"])
    proc = subprocess.run([sys.executable, "-m", "agspec.cli.main", "conform", "--impl", spec, "--no-suite", "-k",
                           "e-coalition-medium-greedy", "-o", "r.jsonl", "--repro-dir", "repro"],
                          cwd=where, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    return where / "r.jsonl"


@pytest.fixture(scope="module")
def browser():
    exe = shutil.which("chromium") or (Path("/usr/bin/chromium").is_file() and "/usr/bin/chromium")
    if not exe:
        pytest.skip("headless browser test needs Debian's chromium (apt-get install chromium); not found")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("headless browser test needs Playwright (pip install '.[test]'); not installed")
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=str(exe), args=CHROMIUM_ARGS)
        yield b
        b.close()


class Page:
    """One loaded page with its console and page errors collected."""

    def __init__(self, browser, path: Path, reduced_motion: bool = False):
        self.errors: list[str] = []
        self.page = browser.new_page(viewport={"width": 1500, "height": 1000},
                                     reduced_motion="reduce" if reduced_motion else "no-preference")
        self.page.on("console", lambda m: self.errors.append(m.text) if m.type == "error" else None)
        self.page.on("pageerror", lambda e: self.errors.append(str(e)))
        self.page.on("request", lambda r: None if r.url.startswith(("file:", "data:"))
                     else self.errors.append(f"network request {r.url}"))
        self.page.goto(path.resolve().as_uri())
        self.page.wait_for_function("window.agspecViewer !== undefined")

    def scrub(self, t: int) -> None:
        self.page.locator("#scrub").evaluate(
            "(el, v) => { el.value = String(v); el.dispatchEvent(new Event('input', {bubbles: true})); }", t)

    def text(self, sel: str) -> str:
        return self.page.inner_text(sel).strip()

    def close(self) -> None:
        self.page.close()
