"""Golden reference traces for conformance items (F-GOLDEN): the reference computed once, reused.

An item's golden trace (:mod:`agspec.formats.golden`) is keyed by everything the reference's replies
depend on — the agspec source, the instance fingerprint, the execution seed, the number of ticks and
the policy (controller and seed, or the script) — and recorded from a live run that passed with
every reply compared (:class:`Recorder`).  A later run of the same item against an implementation
that declares every capability (F-CONFORM-LEVELS level ``full`` with ``diagnostic_state``) is
:func:`replay`-ed: the golden actions are sent and each reply must have the golden digest — the exact
line of a process, else the canonical value.  When every reply does, the item passed
with the counts recorded (RES-GOLDEN-IDENTITY: the invariants and expectations of identical
replies are the recorded ones).  At the first reply that does not, the replay stops and the item
goes on live (:class:`Resumed`: the live reference is stepped through the prefix, whose replies the
implementation had sent identically), so a failure is always found, located and reported by the
live run itself.
"""

from __future__ import annotations

import hashlib
import os
import sys
from functools import lru_cache
from pathlib import Path
from typing import Any, Mapping

import networkx

from agspec.conform.impl import MATCHED, Implementation, Reply
from agspec.conform.items import Item
from agspec.conform.lockstep import driver
from agspec.formats import golden as fmt
from agspec.formats import jsonl, protocol
from agspec.formats import reply as reply_format
from agspec.ir.fingerprint import fingerprint

ENV = "AGSPEC_GOLDEN_CACHE"
# the capabilities a golden replay needs: every reply part the reference sends (F-GOLDEN)
FULL = ("privileged_state", "events", "observations", "masks", "diagnostic_state")


def cache_dir(value: str | None = None) -> Path | None:
    """The cache directory: ``value`` (``--golden-cache``), else $AGSPEC_GOLDEN_CACHE, else
    ``$XDG_CACHE_HOME/agspec/golden`` (``~/.cache/agspec/golden``); ``off`` disables the cache."""
    value = value if value is not None else os.environ.get(ENV)
    if value is not None:
        return None if value.strip().lower() in ("", "off", "none", "0") else Path(value).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "agspec" / "golden"


@lru_cache(maxsize=1)
def source_digest() -> str:
    """SHA-256 over agspec's own source files (path and content): any change of the code that
    computes the reference's replies makes every golden trace another key."""
    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        h.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()


def _dependencies() -> dict[str, str]:
    """Versions of the libraries the reference's replies depend on: the model's graph algorithms, and
    the JSON encoder of the digests (float spellings)."""
    return {"networkx": networkx.__version__, "encoder": fmt.encoder()}


def key(item: Item) -> dict[str, Any]:
    """What the reference's replies to ``item`` depend on (F-GOLDEN key)."""
    if item.controller is not None:
        policy: Any = {"controller": item.controller["name"], "seed": item.controller.get("seed")}
    else:
        policy = {"script": hashlib.sha256(jsonl.dumps({"actions": list(item.actions)}).encode()).hexdigest()}
    return {"format": fmt.GOLDEN_FORMAT, "agspec_source": source_digest(),
            "python": f"{sys.version_info[0]}.{sys.version_info[1]}", "dependencies": _dependencies(),
            "instance": fingerprint(item.instance),
            "execution_seed": item.execution_seed, "ticks": item.ticks, "policy": policy}


def path_of(directory: Path, k: Mapping[str, Any]) -> Path:
    name = hashlib.sha256(jsonl.dumps(k).encode()).hexdigest()
    return directory / name[:2] / f"{name}.json"


def eligible(item: Item, impl: Implementation, tolerance: float | None) -> bool:
    """F-GOLDEN applies to items compared exactly, against an implementation that sends every reply
    part and whose messages nobody else inspects."""
    caps = impl.capabilities
    return (tolerance is None and not impl.validate and impl.on_message is None
            and all(caps.get(c, False) for c in FULL))


def lookup(directory: Path, item: Item) -> fmt.Golden | None:
    """The verified golden trace of ``item``, or None (absent, or a file that does not verify)."""
    k = key(item)
    path = path_of(directory, k)
    if not path.is_file():
        return None
    try:
        return fmt.load(path, k)
    except fmt.GoldenError:
        return None  # never trusted: the live run decides and records a new one


def _same(reply: Reply, digests: tuple[str, str]) -> bool:
    return reply is MATCHED or fmt.value_digest(reply) == digests[1]


def replay(item: Item, impl: Implementation, golden: fmt.Golden) -> tuple[int, list[Any]] | None:
    """Send the golden actions (a process gets several ahead, :meth:`Implementation.pipeline`); at the
    first reply without the golden digest, its index (0: the reset reply) and the replies the
    implementation has sent from there on — that one, then those to the requests still in flight
    (a failure among them last) — for :class:`Resumed`; None when every reply had the golden digest.
    Failures of the implementation propagate (ProtocolError) with ``failure_tick`` set."""
    at = -1  # the tick whose reply is awaited (-1: load and reset)
    try:
        reply = impl.begin(item.instance, item.execution_seed, golden=golden.replies[0])
        if not _same(reply, golden.replies[0]):
            return 0, [reply]
        pipe = impl.pipeline(list(zip(golden.actions, golden.replies[1:])))
        replies = iter(pipe)
        for at, digests in enumerate(golden.replies[1:]):
            reply = next(replies)
            if not _same(reply, digests):
                return at + 1, [reply, *pipe.rest()]
    except Exception as exc:
        exc.failure_tick = at  # type: ignore[attr-defined]
        raise
    return None


class Resumed:
    """The implementation as the live run sees it after a replay stopped at reply ``k`` (F-GOLDEN).
    It has answered every request up to ``k`` and a few more (the pipeline): replies before ``k``
    are those of ``mirror`` (the live reference, asked first — the implementation's had the same
    digests), the replies it already sent are handed out in order (a failure among them is raised
    when its turn comes), and later requests go to it.  No request is sent to it twice."""

    def __init__(self, impl: Implementation, k: int, replies: list[Any], mirror: Implementation,
                 actions: tuple[Mapping[str, int], ...] = ()):
        self.impl, self.k, self.replies, self.mirror = impl, k, list(replies), mirror
        self.actions = actions  # the golden actions, to check the live run sends the same
        self.spec, self.n = impl.spec, 0

    @property
    def capabilities(self) -> dict[str, bool]:
        return self.impl.capabilities

    def start(self) -> dict[str, Any]:
        return self.impl.info

    def load(self, instance: Mapping[str, Any]) -> None:
        pass  # loaded by the replay

    def _answer(self, actions: Mapping[str, int] | None) -> Reply | None:
        n, self.n = self.n, self.n + 1
        if n < self.k:
            return self.mirror.last_reply
        if n - self.k >= len(self.replies):
            return None
        if actions is not None and dict(actions) != dict(self.actions[n - 1]):
            raise RuntimeError(f"the live run sent other actions at tick {n - 1} than the golden trace "
                               "(the reference or the policy is not deterministic)")
        reply = self.replies[n - self.k]
        if isinstance(reply, BaseException):
            raise reply
        return reply

    def reset(self, execution_seed: int | None) -> Reply:
        return self._answer(None)

    def begin(self, instance: Mapping[str, Any] | None, execution_seed: int | None, golden: Any = None) -> Reply:
        return self.reset(execution_seed)  # loaded and reset by the replay

    def step(self, actions: Mapping[str, int]) -> Reply:
        reply = self._answer(actions)
        return self.impl.step(actions) if reply is None else reply

    def close(self) -> None:
        pass  # the implementation belongs to the caller


def counts_at(golden: fmt.Golden, replies: int) -> dict[str, Any]:
    """The recorded counts after ``replies`` replies (reset included) — what the live run had
    counted when its implementation failed on the next request."""
    s = golden.summary
    n = max(0, min(replies, len(golden.replies)))
    return {"states": n, "compared": {p: n for p in s["compared"]},
            "invariant_checks": s["invariant_checks_by_reply"][n - 1] if n else 0,
            "expectations": s["expectations_by_reply"][n - 1] if n else 0,
            "event_types": {t for t, first in s["event_types_from"].items() if first < n}}


class Recorder:
    """An observer of a live run that records its golden trace (the reference's replies as digests,
    the joint actions, the counts after every reply); :meth:`golden` when the item passed."""

    def __init__(self, item: Item, checked: bool = False):
        self.key = key(item)
        # the implementation's replies went through the one decoder and the reply checks (it is not
        # the trusted in-process reference): a reply of the same value vouches for the reference's line
        self.checked = checked
        self.replies: list[tuple[str, str]] = []
        self.actions: list[dict[str, int]] = []
        self.checks: list[int] = []
        self.expectations: list[int] = []
        self.event_types: dict[str, int] = {}
        self.usable = True

    def observe(self, step: driver.Step, invariant_checks: int, expectations: int) -> None:
        value = fmt.value_digest(step.expected)
        vouched = (self.checked and step.actual is not None and step.actual is not step.expected
                   and fmt.value_digest(step.actual) == value)
        if value is None or not (vouched or _accepted(step.expected, "reset" if step.joint is None else "step")):
            self.usable = False
            return
        if step.joint is not None:
            self.actions.append({r: int(a) for r, a in step.joint.items()})
        self.replies.append((fmt.text_digest(step.expected), value))
        self.checks.append(invariant_checks)
        self.expectations.append(expectations)
        for e in step.expected.get("events") or []:
            if isinstance(e, dict) and isinstance(e.get("type"), str):
                self.event_types.setdefault(e["type"], len(self.replies) - 1)

    def golden(self, result: Any) -> fmt.Golden | None:
        if not self.usable or not self.replies or len(self.replies) != len(self.actions) + 1:
            return None
        summary = {"ticks": result.ticks, "states": result.states, "compared": dict(result.compared),
                   "invariant_checks": result.invariant_checks, "expectations": result.expectations,
                   "invariant_checks_by_reply": list(self.checks), "expectations_by_reply": list(self.expectations),
                   "event_types_from": dict(self.event_types)}
        return fmt.Golden(self.key, tuple(self.replies), tuple(self.actions), summary)


def _accepted(reply: Reply, cmd: str) -> bool:
    """RES-GOLDEN-IDENTITY: the line the reference sends for ``reply`` passes the one decoder and the
    reply checks, so that a line with its text digest — which is never decoded — is one a live run
    accepts too.  (A checked implementation's reply with the same value digest vouches for it without
    this: its canonical JSON is the reference line's value, and it passed.)"""
    try:
        value = reply_format.decode_line(jsonl.compact_bytes(reply))
        protocol.check_reply(cmd, value, {c: True for c in FULL})
    except (reply_format.LineError, protocol.ProtocolError, protocol.Unsupported):
        return False
    return True


def store(directory: Path, golden: fmt.Golden) -> None:
    """Write a golden trace into the cache; a cache that cannot be written is only slower."""
    try:
        fmt.dump(golden, path_of(directory, golden.key))
    except OSError:
        pass


__all__ = ["ENV", "FULL", "cache_dir", "source_digest", "key", "eligible", "lookup", "replay", "Resumed",
           "counts_at", "Recorder", "store"]
