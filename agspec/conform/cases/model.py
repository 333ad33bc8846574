"""The conformance suite's case model: :class:`Case`, located errors (:class:`SuiteError`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

CASE_GLOBS = ("*.yaml", "*.yml", "*.json")
STATE_KEYS = ("t", "released", "delivered", "wip", "lost_releases", "robots", "products", "items", "shelves",
              "proposals", "activities")


# =============================================================================================
# errors


@dataclass(frozen=True)
class Located:
    """One problem of the suite, at ``file:line``."""

    file: str
    line: int | None
    message: str

    def __str__(self) -> str:
        where = f"{self.file}:{self.line}" if self.line else self.file
        return f"{where}: {self.message}"


class SuiteError(Exception):
    """A malformed suite: one or more located problems (``file:line: message`` each)."""

    def __init__(self, problems: Located | Sequence[Located]):
        self.problems: list[Located] = [problems] if isinstance(problems, Located) else list(problems)
        super().__init__("\n".join(str(p) for p in self.problems))

    @property
    def file(self) -> str:
        return self.problems[0].file

    @property
    def line(self) -> int | None:
        return self.problems[0].line


# =============================================================================================
# the case


@dataclass(frozen=True)
class Case:
    """One loaded conformance case; ``actions`` are resolved integers, one joint action per tick."""

    id: str
    title: str
    rules: tuple[str, ...]
    invariants: tuple[str, ...]
    tags: tuple[str, ...]
    instance: dict[str, Any] = field(repr=False)
    execution_seed: int | None
    actions: tuple[dict[str, int], ...] = field(repr=False)
    driver: dict[str, Any] | None
    expectations: tuple[dict[str, Any], ...] = field(repr=False)
    source: Path
    line: int
    fingerprint: str = field(default="", repr=False)
    instance_ref: Any = field(default=None, repr=False)  # as written: {"scenario","index"}, a path, or "inline"
    lines: dict[str, int] = field(default_factory=dict, repr=False)  # "script/3", "expectations/0" -> line
    notes: str = field(default="", repr=False)
    root: Path | None = field(default=None, repr=False)  # the suite root instance/trace paths are relative to

    def __hash__(self) -> int:
        return hash(self.id)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Case) and other.id == self.id and other.source == self.source

    @property
    def ticks(self) -> int:
        """How many transitions the case runs."""
        if self.driver is not None and "controller" in self.driver:
            return int(self.driver["ticks"])
        return len(self.actions)

    @property
    def location(self) -> str:
        """``FILE:LINE`` of the case, relative to its suite as the suite's files name it
        (``conformance/cases/support.yaml:12``), wherever the suite is installed."""
        return f"{_show_path(self.source, self.root)}:{self.line}"

    @property
    def needs_observations(self) -> bool:
        return any("observations" in e for e in self.expectations)

    def expectations_at(self, t_after: int) -> list[dict[str, Any]]:
        return [e for e in self.expectations if e["after_tick"] == t_after]

    def line_of(self, key: str) -> int:
        return self.lines.get(key, self.line)


def _show_path(path: Path, root: Path | None = None) -> str:
    """``path`` as its suite names it: relative to the suite root's parent (``conformance/cases/x.yaml``),
    else relative to the working directory, else as it is."""
    for base in ([root.resolve().parent] if root is not None else []) + [Path.cwd().resolve()]:
        try:
            return path.resolve().relative_to(base).as_posix()
        except ValueError:
            continue
    return str(path)
