"""Every command shown in docs/*.md (and README.md) runs as documented.

Convention (also described in docs/validate-and-write-recipes.md, "How the docs are tested"):
in fenced ```console / ```bash blocks, a line starting with ``$ `` is a command, run with bash in a
fresh empty directory — as a reader runs it, with agspec installed and nothing of the repository —
that holds only the files of blocks preceded by ``<!-- file: NAME -->`` and what earlier commands wrote.
``<!-- test: clone -->`` marks a block whose page says it runs from the root of a clone (it uses
``examples/``): it alone gets the clone's ``examples/`` linked.  Lines after a command are expected output (each must occur in
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
    clone: bool = False
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
                elif value == "clone":
                    block.clone = True
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


CLONE = ("examples",)  # what a `clone` block finds beside it
REPO_PATH = re.compile(r"(?<![\w./-])(?:catalogue|conformance|examples|benchmarks|spec|schemas|tests)/")


def _scratch(tmp_path: Path) -> Path:
    """A fresh empty directory (F-DSL-USE: official names need no file of the repository)."""
    where = tmp_path / "fresh"
    where.mkdir()
    return where


def _clone_links(where: Path, on: bool) -> None:
    for name in CLONE:
        link = where / name
        if on and not link.exists():
            link.symlink_to(ROOT / name)
        elif not on and link.is_symlink():
            link.unlink()


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
        _clone_links(where, block.clone)
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


def test_only_clone_blocks_use_repository_paths():
    """A command that reads a repository path runs only from a clone, and says so; the others run
    from a fresh empty directory."""
    wrong = []
    for doc in DOCS:
        for b in extract(doc.read_text(encoding="utf-8")):
            if b.skip or b.clone:
                continue
            texts = [c for c, _ in b.commands] + ([b.text] if b.lang == "python" and not b.file else [])
            texts += [b.text] if b.file and b.lang == "ag" else []
            wrong += [f"{doc.name}:{b.line}: {t.splitlines()[0]}" for t in texts if REPO_PATH.search(t)]
    assert not wrong, wrong


TORCH = "torch==2.13.0"  # the CPU build; an unpinned torch (or the `train` extra alone) pulls a CUDA build


def test_every_install_of_torch_pins_the_cpu_build():
    """Every docs line that installs PyTorch, directly or through the `train` extra, installs the
    pinned CPU build first (on the same line or an earlier line of the same block)."""
    wrong = []
    for doc in DOCS:
        text = doc.read_text(encoding="utf-8")
        for block in [b.text for b in extract(text)] + ["\n".join(re.findall(r"`([^`]*pip install[^`]*)`", text))]:
            pinned = False
            for line in block.splitlines():
                if "pip install" not in line:
                    continue
                pinned = pinned or TORCH in line
                if re.search(r"\btorch\b|\[[^\]]*\btrain\b", line.split("#")[0]) and not pinned:
                    wrong.append(f"{doc.name}: {line.strip()}")
    assert not wrong, wrong


def test_every_doc_shows_at_least_one_tested_command():
    """The user guides exercise their commands (reproduction.md is generated, not a guide)."""
    for name in ("validate-and-write-recipes.md", "run-and-evaluate.md", "conformance.md"):
        doc = ROOT / "docs" / name
        assert any(b.commands for b in extract(doc.read_text(encoding="utf-8")) if not b.skip), name
