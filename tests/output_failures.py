"""The generator of F-OUTPUT-FAILURES: every output of every command × every way its target can fail.

Used by tests/test_output_failures.py (the table, each row a test) and benchmarks/output_failures.py
(the whole table with its figures). Each row runs ``agspec`` in a subprocess — a failing target is a
property of the process (its standard output, its file-size limit) — with tiny inputs (5 ticks,
one instance, no suite) and judges the outcome:

* exit 2, or 0 when standard output is a closed pipe (``| head -1``);
* no traceback, and exactly one ``error:`` line, naming the target and the operating system's reason;
* nothing under the target's name a reader would take as complete (no file; a stream without its
  footer), and no temporary file left beside it.

Targets: ``full`` (/dev/full), ``under-file`` (a path below a regular file), ``missing-dir`` (a file
in a directory that does not exist; a directory output creates it and succeeds), ``unwritable`` (a
directory made immutable with ``chattr +i``: root ignores permission bits), ``fsize`` (RLIMIT_FSIZE
of 100 bytes with SIGXFSZ ignored, so writes fail with EFBIG), and for standard output ``stdout-full``,
``stdout-closed`` (file descriptor 1 closed) and ``stdout-pipe`` (the reading end already closed).
"""

from __future__ import annotations

import dataclasses
import json
import os
import re
import resource
import shutil
import signal
import subprocess
import sys
from pathlib import Path
from typing import Callable

ROOT = Path(__file__).resolve().parents[1]
AGSPEC = [sys.executable, "-c", "from agspec.cli.main import main; import sys; main(sys.argv[1:])"]
FAKE = f"{sys.executable} {ROOT / 'tests' / 'fakes' / 'fake_sim.py'} mutate"
FLOW = str(ROOT / "catalogue" / "scenarios" / "flow-easy.ag")
FSIZE = 100
TIMEOUT = 60  # seconds a row may run (every row's inputs are tiny)
# a recipe `fmt --write` rewrites: the shipped one with a space too many
NON_CANONICAL = (ROOT / "catalogue" / "recipes" / "solo_inspection.ag").read_text(encoding="utf-8").replace(
    "\nrecipe ", "\nrecipe  ", 1)
CONFORM = ["conform", "--no-suite", "--episodes", "1", "--horizon", "5", "-k", "flow-easy"]

FILE_TARGETS = ("full", "under-file", "missing-dir", "unwritable", "fsize")
STDOUT_TARGETS = ("stdout-full", "stdout-closed", "stdout-pipe")


@dataclasses.dataclass(frozen=True)
class Output:
    """One output of one command: ``argv`` with ``{out}`` (the target) and the inputs ``{trace}``,
    ``{bundle}``, ``{tmp}``; ``kind`` file (written whole), stream (record by record, ends with its
    completeness mark), dir (a directory of files) or stdout; ``rc`` its exit status when nothing fails."""

    name: str
    argv: tuple[str, ...]
    kind: str
    suffix: str = ".json"
    rc: int = 0
    targets: tuple[str, ...] | None = None  # default: all of the kind's
    fsize: int = FSIZE  # bytes a file may grow to under the `fsize` target
    rewrites: bool = False  # the output is its own input, rewritten (`fmt --write`): placed first, kept intact

    def target_names(self) -> tuple[str, ...]:
        return self.targets or (STDOUT_TARGETS if self.kind == "stdout" else FILE_TARGETS)


def _o(name: str, *argv: str, kind: str = "file", suffix: str = ".json", rc: int = 0,
       targets: tuple[str, ...] | None = None, fsize: int = FSIZE, rewrites: bool = False) -> Output:
    return Output(name, tuple(argv), kind, suffix, rc, targets, fsize, rewrites)


OUTPUTS: tuple[Output, ...] = (
    # whole files
    _o("compile -o", "compile", FLOW, "-o", "{out}"),
    _o("instance -o", "instance", "flow-easy", "-o", "{out}"),
    _o("export -o", "export", "flow-easy", "-o", "{out}"),
    _o("catalogue verify --update --lock", "catalogue", "verify", "--update", "--lock", "{out}"),
    _o("render -o", "render", "{trace}", "-o", "{out}", suffix=".html"),
    _o("report --to markdown -o", "report", "{bundle}", "--to", "markdown", "-o", "{out}", suffix=".md"),
    _o("report --to svg -o", "report", "{bundle}", "--to", "svg", "-o", "{out}", suffix=".svg"),
    # a file rewritten in place: only the targets an existing input can be in
    _o("fmt --write", "fmt", "--write", "{out}", suffix=".ag", targets=("unwritable", "fsize"), rewrites=True),
    # streams
    _o("run --trace", "run", "flow-easy", "--horizon", "5", "--trace", "{out}", kind="stream", suffix=".jsonl"),
    _o("render --impl --trace", "render", "--impl", "reference", "--scenario", "flow-easy", "--horizon", "5",
       "--trace", "{out}", "-o", "{tmp}/page.html", kind="stream", suffix=".jsonl"),
    _o("conform -o", *CONFORM, "--impl", "reference", "-o", "{out}", kind="stream", suffix=".jsonl"),
    _o("check -o", "check", "{trace}", "{trace}", "-o", "{out}", kind="stream", suffix=".jsonl"),
    _o("evaluate -o", "evaluate", "--controller", "greedy", "--scenario", "flow-easy", "--indices", "1000-1000",
       "-o", "{out}", kind="stream"),
    # directories
    _o("conform --repro-dir", *CONFORM, "--impl", FAKE, "--repro-dir", "{out}", kind="dir", rc=1),
    _o("conform -j 2 --repro-dir", *CONFORM, "-j", "2", "--impl", FAKE, "--repro-dir", "{out}", kind="dir", rc=1,
       targets=("under-file", "fsize"), fsize=2000),  # the reproducer is written in a worker process (the
    #                                                  workers' own marker files stay under 2000 bytes)
    _o("conform --golden-cache", *CONFORM, "--impl", "reference", "--golden-cache", "{out}", kind="dir"),
    _o("diff -o", "diff", "--impl", "reference", "--impl", FAKE, "--scenario", "flow-easy", "--indices", "0-0",
       "--horizon", "5", "--controller", "greedy", "--small", "0", "--shrink-budget", "0", "-o", "{out}",
       kind="dir", rc=1),
    # the paper's whole plan runs minutes: only the targets found before it runs
    _o("evaluate --paper -o", "evaluate", "--paper", "-o", "{out}", kind="dir",
       targets=("full", "under-file", "unwritable")),
    # standard output
    _o("compile", "compile", FLOW, kind="stdout"),
    _o("fmt", "fmt", FLOW, kind="stdout"),
    _o("validate --format json", "validate", FLOW, "--format", "json", kind="stdout"),
    _o("instance", "instance", "flow-easy", kind="stdout"),
    _o("export", "export", "flow-easy", kind="stdout"),
    _o("fingerprint", "fingerprint", "flow-easy", kind="stdout"),
    _o("catalogue list", "catalogue", "list", kind="stdout"),
    _o("explain", "explain", "F-EXIT-CODES", kind="stdout"),
    _o("run", "run", "flow-easy", "--horizon", "5", kind="stdout"),
    _o("run --format json", "run", "flow-easy", "--horizon", "5", "--format", "json", kind="stdout"),
    _o("evaluate --format json", "evaluate", "--controller", "greedy", "--scenario", "flow-easy", "--indices",
       "1000-1000", "--format", "json", kind="stdout"),
    _o("conform", *CONFORM, "--impl", "reference", kind="stdout"),
    _o("conform --format json", *CONFORM, "--impl", "reference", "--format", "json", kind="stdout"),
    _o("check", "check", "{trace}", kind="stdout"),
    _o("check --format json", "check", "{trace}", "{trace}", "--format", "json", kind="stdout"),
    _o("trace validate", "trace", "validate", "{trace}", kind="stdout"),
    _o("report --to markdown", "report", "{bundle}", "--to", "markdown", kind="stdout"),
    _o("diff --format json", "diff", "--impl", "reference", "--impl", "reference", "--scenario", "flow-easy",
       "--indices", "0-0", "--horizon", "5", "--controller", "greedy", "--small", "0", "--format", "json",
       kind="stdout"),
    _o("train --print-config", "train", "--algorithm", "ippo", "--scenario", "flow-easy", "--seed", "0",
       "--print-config", "-o", "{tmp}/run", kind="stdout"),
)


def train_outputs() -> tuple[Output, ...]:
    """`agspec train -o DIR` (needs torch): a run directory of two updates."""
    return (_o("train -o", "train", "--algorithm", "ippo", "--scenario", "flow-easy", "--seed", "0", "--steps", "10",
               "--threads", "1", "--set", "ppo.steps_per_update=2", "--set", "ppo.minibatch=32",
               "--set", "validation.indices=[]", "--set", "record.every_steps=2", "-o", "{out}", kind="dir"),)


def cases(outputs: tuple[Output, ...] = OUTPUTS) -> list[tuple[Output, str]]:
    return [(o, t) for o in outputs for t in o.target_names()]


# --------------------------------------------------------------------------- inputs


def make_inputs(base: Path) -> dict[str, str]:
    """A 5-tick trace and a one-episode results bundle, made once."""
    trace, bundle = base / "input.jsonl", base / "input-bundle.json"
    env = _env(base)
    if not trace.exists():
        subprocess.run([*AGSPEC, "run", "flow-easy", "--horizon", "5", "--trace", str(trace)], check=True,
                       capture_output=True, env=env, cwd=base)
    if not bundle.exists():
        subprocess.run([*AGSPEC, "evaluate", "--controller", "greedy", "--scenario", "flow-easy", "--indices",
                        "1000-1000", "-o", str(bundle)], check=True, capture_output=True, env=env, cwd=base)
    return {"trace": str(trace), "bundle": str(bundle)}


def _env(base: Path) -> dict[str, str]:
    env = dict(os.environ, AGSPEC_GOLDEN_CACHE="off", COLUMNS="200", XDG_CACHE_HOME=str(base / "cache"))
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    env.pop("AGSPEC_REPRO_DIR", None)
    return env


# --------------------------------------------------------------------------- one row


@dataclasses.dataclass
class Outcome:
    output: Output
    target: str
    path: str
    rc: int
    stderr: str
    problems: list[str]

    @property
    def ok(self) -> bool:
        return not self.problems


def _immutable(directory: Path) -> bool:
    directory.mkdir(parents=True, exist_ok=True)
    if shutil.which("chattr") is None:
        return False
    return subprocess.run(["chattr", "+i", str(directory)], capture_output=True).returncode == 0


def _release(directory: Path) -> None:
    if directory.exists() and shutil.which("chattr"):
        subprocess.run(["chattr", "-i", str(directory)], capture_output=True)


def _complete(path: Path, output: Output) -> bool:
    """Would a reader take ``path`` as a complete result?"""
    if output.kind == "dir":
        return False
    if not path.is_file():
        return False
    text = path.read_text(encoding="utf-8", errors="replace")
    if output.kind == "stream" and output.suffix == ".jsonl":
        last = text.rstrip("\n").rsplit("\n", 1)[-1]
        try:
            return json.loads(last).get("type") == "footer"
        except (ValueError, AttributeError):
            return False
    if output.kind == "stream":
        try:
            return json.loads(text).get("complete") is True
        except (ValueError, AttributeError):
            return False
    return True


def run_case(output: Output, target: str, base: Path, inputs: dict[str, str]) -> Outcome:
    """Run one row in its own directory under ``base``; judge it (F-OUTPUT-FAILURES)."""
    work = base / re.sub(r"[^A-Za-z0-9]+", "_", f"{output.name}-{target}")
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    name = "result" + (output.suffix if output.kind != "dir" else "")
    expect_fail, locked = True, None
    if target == "full":
        path = Path("/dev/full")
    elif target == "under-file":
        (work / "afile").write_text("x\n")
        path = work / "afile" / name
    elif target == "missing-dir":
        path = work / "missing" / name
        expect_fail = output.kind != "dir"  # a directory output creates its parents
    elif target == "unwritable":
        locked = work / "locked"
        locked.mkdir()
        if output.rewrites:
            (locked / name).write_text(NON_CANONICAL, encoding="utf-8")
        if not _immutable(locked):
            return Outcome(output, target, str(locked), -1, "", ["skip: chattr +i is not available"])
        path = locked / name
    else:
        path = work / name
        if output.rewrites:
            path.write_text(NON_CANONICAL, encoding="utf-8")
    stdout_target = output.kind == "stdout"
    argv = [a.format(out=path, tmp=work, **inputs) for a in output.argv]
    pipe_r = pipe_w = None
    stdout: int | object = subprocess.DEVNULL
    preexec: Callable[[], None] | None = None
    if target == "fsize":
        def preexec() -> None:
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
            resource.setrlimit(resource.RLIMIT_FSIZE, (output.fsize, output.fsize))
    elif target == "stdout-full":
        stdout = open("/dev/full", "w")
    elif target == "stdout-closed":
        def preexec() -> None:
            os.close(1)
    elif target == "stdout-pipe":
        pipe_r, pipe_w = os.pipe()
        os.close(pipe_r)  # the reader is gone before the first line (`| head -0`)
        stdout = pipe_w
    try:
        proc = subprocess.Popen([*AGSPEC, *argv], stdout=stdout, stderr=subprocess.PIPE, text=True,
                                env=_env(base), cwd=work, preexec_fn=preexec, start_new_session=True)
        try:
            _, err = proc.communicate(timeout=TIMEOUT)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)  # its own session: the command and its workers
            proc.communicate()
            return Outcome(output, target, str(path), -9, "", [f"still running after {TIMEOUT} s (the target's "
                                                                "failure is found only at the end)"])
    finally:
        if pipe_w is not None:
            os.close(pipe_w)
        if hasattr(stdout, "close"):
            stdout.close()  # type: ignore[union-attr]
        if locked is not None:
            _release(locked)
    problems: list[str] = []
    shown = "<stdout>" if stdout_target else str(path)
    if not expect_fail:
        if proc.returncode != output.rc:
            problems.append(f"exit {proc.returncode}, expected {output.rc} (the directory is created)")
        if not path.is_dir():
            problems.append(f"{path} was not created")
    else:
        want = 0 if target == "stdout-pipe" else 2
        if proc.returncode != want:
            problems.append(f"exit {proc.returncode}, expected {want}")
        errors = [line for line in err.splitlines() if line.startswith("error")]
        if target == "stdout-pipe":
            if errors:
                problems.append(f"a closed pipe is not an error, got {errors[0]!r}")
        elif len(errors) != 1:
            problems.append(f"{len(errors)} error lines, expected 1: {errors[:3]}")
        elif not (shown in errors[0] or (locked is not None and str(locked) in errors[0])):
            problems.append(f"the error does not name {shown}: {errors[0]!r}")
        elif errors[0].startswith("error: cannot write ") and not re.search(r": [A-Z][^:]*$", errors[0]):
            problems.append(f"the error gives no reason: {errors[0]!r}")
    if "Traceback" in err:
        problems.append("traceback: " + err[err.index("Traceback"):][-300:].replace("\n", " | "))
    if output.rewrites:
        if path.read_text(encoding="utf-8") != NON_CANONICAL:
            problems.append(f"{path}, the input, was changed")
    elif expect_fail and not stdout_target and path != Path("/dev/full") and _complete(path, output):
        problems.append(f"{path} is left looking complete")
    if expect_fail and output.kind == "dir" and path.is_dir():
        for file in path.rglob("*"):
            if file.is_file() and file.suffix == ".json":
                try:
                    json.loads(file.read_text(encoding="utf-8"))
                except ValueError:
                    problems.append(f"{file} is left half-written")
            if ".tmp" in file.name:
                problems.append(f"temporary file left: {file}")
    parent = path.parent if path.parent.is_dir() else None
    if parent is not None and str(parent).startswith(str(base)):
        left = [p.name for p in parent.iterdir() if ".tmp" in p.name]
        if left:
            problems.append(f"temporary files left: {left}")
    return Outcome(output, target, str(path), proc.returncode, err, problems)


__all__ = ["OUTPUTS", "Output", "Outcome", "cases", "make_inputs", "run_case", "train_outputs"]
