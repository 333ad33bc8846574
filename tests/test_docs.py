"""Every command shown in docs/*.md (and README.md) runs as documented.

Convention (also described in docs/validate-and-write-recipes.md, "How the docs are tested"):
in fenced ```console / ```bash blocks, a line starting with ``$ `` is a command, run with bash in a
scratch directory that links ``catalogue/``, ``conformance/`` and ``examples/`` and holds the files of blocks
preceded by ``<!-- file: NAME -->``.  Lines after a command are expected output (each must occur in
stdout+stderr; ``...`` lines are skipped).  ``<!-- test: exit=N -->`` before a block sets the expected
exit status (default 0), ``<!-- test: slow -->`` marks it slow, ``<!-- test: skip -->`` excludes it.
Fenced ```python blocks without a file marker are run as scripts in the same directory.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = sorted((ROOT / "docs").glob("*.md")) + [ROOT / "README.md"]
FENCE = re.compile(r"^```(\w*)\s*$")
MARKER = re.compile(r"^<!--\s*(test|file):\s*(.*?)\s*-->\s*$")
ANSI = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")


@dataclass
class Block:
    lang: str
    text: str
    line: int
    file: str | None = None
    exit: int = 0
    slow: bool = False
    skip: bool = False
    commands: list[tuple[str, list[str]]] = field(default_factory=list)


def extract(text: str) -> list[Block]:
    """Fenced blocks with their markers; console/bash blocks get (command, expected lines) pairs."""
    lines = text.splitlines()
    blocks: list[Block] = []
    markers: list[tuple[str, str]] = []
    i = 0
    while i < len(lines):
        m = MARKER.match(lines[i])
        if m:
            markers.append((m.group(1), m.group(2)))
            i += 1
            continue
        f = FENCE.match(lines[i])
        if f and f.group(1):
            end = i + 1
            while end < len(lines) and lines[end].strip() != "```":
                end += 1
            block = Block(f.group(1), "\n".join(lines[i + 1:end]) + "\n", i + 1)
            for kind, value in markers:
                if kind == "file":
                    block.file = value
                elif value == "slow":
                    block.slow = True
                elif value == "skip":
                    block.skip = True
                elif value.startswith("exit="):
                    block.exit = int(value[5:])
            if block.lang in ("console", "bash"):
                for body in block.text.splitlines():
                    if body.startswith("$ "):
                        block.commands.append((body[2:], []))
                    elif block.commands and body.strip() and body.strip() != "...":
                        block.commands[-1][1].append(body.rstrip())
            blocks.append(block)
            markers = []
            i = end + 1
            continue
        if lines[i].strip():
            markers = []
        i += 1
    return blocks


def _scratch(tmp_path: Path) -> Path:
    for name in ("catalogue", "conformance", "examples"):
        (tmp_path / name).symlink_to(ROOT / name)
    return tmp_path


def _env() -> dict[str, str]:
    env = dict(os.environ, COLUMNS="200", NO_COLOR="1", TERM="dumb")
    bindir = str(Path(sys.executable).parent)
    env["PATH"] = bindir + os.pathsep + env.get("PATH", "")  # `python` and `agspec` of this interpreter
    return env


def run_blocks(blocks: list[Block], where: Path, doc: str) -> None:
    for block in blocks:
        if block.skip:
            continue
        if block.file:
            (where / block.file).write_text(block.text, encoding="utf-8")
            continue
        if block.lang == "python":
            proc = subprocess.run([sys.executable, "-c", block.text], cwd=where, env=_env(), capture_output=True,
                                  text=True, timeout=600)
            assert proc.returncode == 0, f"{doc}:{block.line}: python block failed\n{proc.stderr[-3000:]}"
            continue
        for command, expected in block.commands:
            proc = subprocess.run(["bash", "-c", command], cwd=where, env=_env(), capture_output=True, text=True,
                                  timeout=1800)
            output = ANSI.sub("", proc.stdout + proc.stderr)
            assert proc.returncode == block.exit, (
                f"{doc}:{block.line}: `{command}` exited {proc.returncode}, documented {block.exit}\n{output[-3000:]}")
            for line in expected:
                assert line.strip() in output, f"{doc}:{block.line}: `{command}` did not print:\n{line}\n---\n{output[-3000:]}"


def _params(slow: bool):
    out = []
    for doc in DOCS:
        blocks = extract(doc.read_text(encoding="utf-8"))
        if any(b.commands or (b.lang == "python" and not b.file) for b in blocks if b.slow == slow and not b.skip):
            ray = any("--executor ray" in c for b in blocks if not b.skip for c, _ in b.commands)
            out.append(pytest.param(doc, id=doc.name, marks=[pytest.mark.ray] if ray else []))
    return out


def _select(doc: Path, slow: bool) -> list[Block]:
    """Fast run: the fast blocks (and every file block); slow run: everything, in order."""
    return [b for b in extract(doc.read_text(encoding="utf-8")) if slow or not b.slow or b.file]


@pytest.mark.parametrize("doc", _params(slow=False))
def test_doc_commands_run_as_documented(doc: Path, tmp_path: Path):
    run_blocks(_select(doc, slow=False), _scratch(tmp_path), doc.name)


@pytest.mark.slow
@pytest.mark.parametrize("doc", _params(slow=True))
def test_doc_slow_commands_run_as_documented(doc: Path, tmp_path: Path):
    run_blocks(_select(doc, slow=True), _scratch(tmp_path), doc.name)


def test_extractor_follows_the_convention():
    text = ("<!-- file: a.ag -->\n```ag\nrecipe x {}\n```\n\n<!-- test: exit=1 -->\n<!-- test: slow -->\n"
            "```console\n$ agspec validate a.ag\nerror[AG1\n...\n$ echo hi\n```\n```python\nprint(1)\n```\n"
            "<!-- test: skip -->\n```bash\n$ false\n```\n")
    file_block, console, python, skipped = extract(text)
    assert file_block.file == "a.ag" and file_block.text == "recipe x {}\n"
    assert (console.exit, console.slow, console.file) == (1, True, None)
    assert console.commands == [("agspec validate a.ag", ["error[AG1"]), ("echo hi", [])]
    assert python.lang == "python" and python.exit == 0 and not python.slow
    assert skipped.skip and skipped.commands == [("false", [])]


def test_every_doc_shows_at_least_one_tested_command():
    """The user guides exercise their commands (reproduction.md is generated, not a guide)."""
    for name in ("validate-and-write-recipes.md", "run-and-evaluate.md", "conformance.md"):
        doc = ROOT / "docs" / name
        assert any(b.commands for b in extract(doc.read_text(encoding="utf-8")) if not b.skip), name
