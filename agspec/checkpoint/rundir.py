"""The run directory (spec/16-training.md, T-RUN-DIR): names, the summary file, completeness.

    CONFIG       the resolved configuration (canonical JSON)
    SUMMARY      the run summary (schemas/training-run.schema.json), rewritten as the run goes
    RECORD       the training record (schemas/training-record.schema.json), appended as it goes
    CHECKPOINT   the last resumable state (networks, optimizers, random streams, counters)
    replay-N.npz QMIX only: the replay buffer at the checkpoint taken after N steps
    POLICY       the final policy: the network the evaluation runs (its SHA-256 is its identity)

No torch here: a campaign inspects run directories without the extra.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
from pathlib import Path
from typing import Any, Iterator, Mapping

from agspec.formats import output
from agspec.formats.digest import file_sha256
from agspec.formats.limits import InputError, load_json
from agspec.formats.schemas import integers_of

RUN_SCHEMA = "agspec-training-run/1"
CONFIG, SUMMARY, RECORD, CHECKPOINT, POLICY, LOCK = (
    "config.json", "run.json", "record.jsonl", "checkpoint.pt", "policy.pt", ".lock")
REPLAY_GLOB = "replay-*.npz"


def replay_name(steps: int) -> str:
    """The QMIX replay saved with the checkpoint taken after ``steps`` environment steps."""
    return f"replay-{steps:012d}.npz"


class RunDirError(ValueError):
    """A run directory that cannot be used as asked (the message says why and what to do)."""


def write_json_atomic(path: Path, data: Any) -> None:
    """Write JSON through a temporary file and a rename, so a cut never leaves half a file."""
    output.write_text(path, json.dumps(data, indent=2, sort_keys=True) + "\n")  # F-OUTPUT-FAILURES


def read_json(path: Path) -> Any:
    try:
        return load_json(path)
    except InputError as exc:
        raise RunDirError(str(exc)) from None


def read_summary(run_dir: str | os.PathLike) -> dict[str, Any]:
    """The run summary ``run.json`` of a run directory (RunDirError when there is none)."""
    path = Path(run_dir) / SUMMARY
    if not path.is_file():
        raise RunDirError(f"{run_dir}: not a training run directory (no {SUMMARY})")
    data = read_json(path)
    if not isinstance(data, dict) or data.get("schema") != RUN_SCHEMA:
        raise RunDirError(f"{path}: not a training run summary (schema {RUN_SCHEMA} expected)")
    return integers_of("training-run", data)  # F-VALUES, RES-INTEGRAL-NUMBERS


def is_complete(out_dir: str | os.PathLike) -> bool:
    """True iff the run finished: ``run.json`` says complete and its final policy file has the recorded digest."""
    try:
        summary = read_summary(out_dir)
    except RunDirError:
        return False
    policy = summary.get("policy") or {}
    path = Path(out_dir) / POLICY
    return summary.get("status") == "complete" and path.is_file() and policy.get("sha256") == file_sha256(path)


def refuse_foreign(out_dir: Path) -> None:
    """RunDirError for a path that is a file, or a non-empty directory that holds no training run."""
    if out_dir.exists() and not out_dir.is_dir():
        raise RunDirError(f"{out_dir} exists and is not a directory")
    if out_dir.is_dir() and not (out_dir / CONFIG).is_file() and any(p.name != LOCK for p in out_dir.iterdir()):
        raise RunDirError(f"{out_dir} is not empty and holds no training run; choose another -o/--output directory")


@contextlib.contextmanager
def exclusive(out_dir: Path) -> Iterator[None]:
    """T-RUN-DIR: one process trains into a run directory at a time (an advisory lock on its ``.lock``,
    released when the process ends however it ends)."""
    output.make_dir(out_dir)  # F-OUTPUT-FAILURES: an unusable directory is found before training
    try:
        fh = open(out_dir / LOCK, "a")
    except OSError as exc:
        raise output.OutputError(out_dir / LOCK, exc) from None
    with fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise RunDirError(f"{out_dir}: another process is training into this directory") from None
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def prepare(out_dir: Path, config: Mapping[str, Any], resume: bool) -> bool:
    """Check ``out_dir`` against the run about to start; True when there is a checkpoint to resume.

    A new run needs an empty or missing directory; ``resume`` needs the same configuration.
    """
    config_path = out_dir / CONFIG
    if not out_dir.exists():
        out_dir.mkdir(parents=True)
        return False
    if not out_dir.is_dir():
        raise RunDirError(f"{out_dir} exists and is not a directory")
    if not config_path.is_file():
        if any(p.name != LOCK for p in out_dir.iterdir()):
            raise RunDirError(f"{out_dir} is not empty and holds no training run; choose another -o/--output directory")
        return False
    if not resume:
        raise RunDirError(f"{out_dir} already holds a training run; add --resume to continue it, or choose another -o/--output directory")
    stored = read_json(config_path)
    if stored != json.loads(json.dumps(config)):
        diff = sorted(_differences(stored, config))
        raise RunDirError(f"{out_dir} holds a run with another configuration ({', '.join(diff[:5])}); "
                          "resume it with the same settings, or choose another -o/--output directory")
    return (out_dir / CHECKPOINT).is_file()


def _differences(a: Any, b: Any, prefix: str = "") -> list[str]:
    if isinstance(a, Mapping) and isinstance(b, Mapping):
        out = []
        for key in sorted(set(a) | set(b)):
            out += _differences(a.get(key), b.get(key), f"{prefix}{key}.")
        return out
    return [] if a == b else [prefix.rstrip(".")]
