"""The training record (spec/16-training.md, T-RECORD; schemas/training-record.schema.json).

JSON Lines, one object per line, appended and flushed as the run goes: a ``header``, then
``progress`` rows (every ``record.every_steps`` environment steps and at each block's end: the
episodes finished since the previous row — milestone return, admissions, delivered — and the
learner's diagnostics: policy entropy and critic explained variance for IPPO/MAPPO, ε and the TD
loss for QMIX) and ``validation`` rows (T-VALIDATION).  A resumed run cuts the file back to the
length its checkpoint recorded, so a resumed record equals an uncut one but for wall times.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any, Iterable, Iterator, Mapping

import numpy as np

from agspec.formats.limits import InputError, iter_json_lines
from agspec.formats.output import OutputError
from agspec.formats.schemas import integers_of

RECORD_SCHEMA = "agspec-training-record/1"
EPISODE_KEYS = ("milestone_return", "admissions", "delivered", "length")
# fields that measure the machine, not the run: left out when two records are compared
WALL_FIELDS = ("elapsed_s",)


def _mean(values: list[float]) -> float | None:
    return float(np.mean(values)) if values else None


def episode_means(episodes: Iterable[Mapping[str, float]]) -> dict[str, Any]:
    """Means over the finished episodes (null when none finished): the curves of the paper's figures."""
    eps = list(episodes)
    out: dict[str, Any] = {"episodes": len(eps)}
    for key in EPISODE_KEYS:
        out[key if key != "length" else "episode_length"] = _mean([float(e[key]) for e in eps])
    return out


class Record:
    """Appends rows to ``record.jsonl``; ``truncate`` cuts it back to a checkpoint's length."""

    def __init__(self, path: Path):
        self.path = path

    def size(self) -> int:
        return self.path.stat().st_size if self.path.exists() else 0

    def truncate(self, size: int) -> None:
        with open(self.path, "r+b") as fh:
            fh.truncate(size)

    def write(self, row: Mapping[str, Any]) -> None:
        try:
            with open(self.path, "a", encoding="utf-8") as fh:
                fh.write(json.dumps(row, sort_keys=True, allow_nan=False) + "\n")
                fh.flush()
                os.fsync(fh.fileno())
        except OSError as exc:  # F-OUTPUT-FAILURES
            raise OutputError(self.path, exc) from None


def read_record(path: Path) -> Iterator[dict[str, Any]]:
    """The rows of a training record (bounded reading, F-LIMITS); a bad line raises InputError.  F-VALUES,
    RES-INTEGRAL-NUMBERS: a count written ``2.0`` is read as the integer 2."""
    for _lineno, value in iter_json_lines(path):
        if isinstance(value, InputError):
            raise value
        yield integers_of("training-record", value)


def without_wall_time(rows: Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """The rows with the machine-dependent fields removed (for comparing two runs)."""
    return [{k: v for k, v in row.items() if k not in WALL_FIELDS} for row in rows]
