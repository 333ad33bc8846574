"""F-EXIT-CODES and RES-EXIT-CONTENT: every command that reads a file, on every fault class.

A table: each command of ``hostile_inputs.COMMANDS`` x each hostile input of its family. A fault in
reaching the file (missing, directory, FIFO, /dev/zero) exits 2; a fault in its content (encoding,
an F-LIMITS limit, syntax, duplicate keys, NaN, wrong types, empty) exits 1; always with a message,
never with a traceback, and never blocking (a FIFO is refused before it is opened).
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from contextlib import contextmanager

import pytest

from hostile_inputs import CONTENT, COMMANDS, FAMILIES, SPECIAL, TRACEBACK, argv, expected_exit, invoke, materialize




@contextmanager
def deadline(seconds: int):
    """Fail instead of hanging when a command blocks (e.g. on a FIFO)."""
    def expire(signum, frame):
        raise TimeoutError(f"the command did not return within {seconds} s")

    old = signal.signal(signal.SIGALRM, expire)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


@pytest.mark.parametrize("command", sorted(COMMANDS))
@pytest.mark.parametrize("kind", [*CONTENT, *SPECIAL])
def test_every_command_on_every_bad_input(command, kind, tmp_path):
    family = FAMILIES[COMMANDS[command][0]]
    path = materialize(kind, family, tmp_path)
    if path is None:
        pytest.skip(f"{kind} does not apply to {family.name} files")
    with deadline(60):
        out = invoke(argv(command, path, tmp_path))
    assert not out.crashed, out.output
    assert not TRACEBACK.search(out.output)
    assert out.exit_code == expected_exit(kind), out.output[-2000:]
    assert out.output.strip(), "a failing command must say why"


@pytest.mark.parametrize("command", ["validate", "check", "run"])
def test_a_fifo_is_refused_by_the_real_entry_point(command, tmp_path):
    """Through the console script (a fresh process): exit 2 at once, no traceback, nothing blocks."""
    family = FAMILIES[COMMANDS[command][0]]
    path = materialize("fifo", family, tmp_path)
    proc = subprocess.run([sys.executable, "-m", "agspec.cli.main", *argv(command, path, tmp_path)],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and "not a regular file" in proc.stderr and "Traceback" not in proc.stderr


def test_a_suite_with_a_broken_case_file_is_invalid_input(tmp_path):
    (tmp_path / "cases").mkdir()
    (tmp_path / "cases" / "bad.yaml").write_text("a: [1, 2\n", encoding="utf-8")
    out = invoke(["conform", "--impl", "reference", "--suite", str(tmp_path)])
    assert not out.crashed and out.exit_code == 1 and "bad.yaml:2" in out.output


@pytest.mark.parametrize("command", [
    ["evaluate", "--scenario", "coalition-medium", "--split", "final-test", "--controller", "greedy",
     "--format", "json"],
    ["conform", "--impl", "agspec serve", "--no-suite", "--episodes", "2", "--horizon", "400"],
])
def test_an_interrupted_run_exits_130(command):
    # F-EXIT-CODES: Ctrl-C is "interrupted" (130), not click's "Aborted!" (1); the run is long enough
    # to be interrupted mid-campaign whatever the machine's speed
    proc = subprocess.Popen([sys.executable, "-m", "agspec.cli.main", *command], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)
    try:
        time.sleep(4)
        proc.send_signal(signal.SIGINT)
        err = proc.communicate(timeout=120)[1]
    finally:
        proc.kill()
    assert proc.returncode == 130, err[-500:]
    assert not TRACEBACK.search(err)
