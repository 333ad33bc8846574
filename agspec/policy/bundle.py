"""The results bundle ``agspec-results/1`` (F-POLICY-BUNDLE, schema ``schemas/results.schema.json``).

Written incrementally: the header (versions, catalogue digest, host, policies, instances) first,
then one episode record per line as each episode ends, so an interrupted campaign leaves every
finished episode on disk.  On a normal end the file is rewritten once, complete.  A bundle whose
tail is missing is read back up to its last whole record and marked ``complete: false``.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import sys
from pathlib import Path
from typing import Any, Iterable, Mapping

from agspec import SPEC_VERSION, __version__
from agspec.formats import limits, output
from agspec.formats.schemas import integers_of, self_check, validate
from agspec.policy.coverage import Planned, merge, planned_entries, planned_of_bundle
from agspec.policy.trained import with_action

FORMAT = "agspec-results/1"


class BundleError(ValueError):
    """A bundle cannot be read, violates its schema, or does not combine with the others (exit 2)."""


def catalogue_digest() -> str:
    """sha256 of the catalogue lock's canonical text (F-LOCK): which official catalogue was run."""
    from agspec.catalogue import lock_text, read_lock

    return hashlib.sha256(lock_text(read_lock()).encode("utf-8")).hexdigest()


def host_facts() -> dict[str, Any]:
    """What a reader needs to interpret wall times."""
    return {"python": platform.python_version(), "implementation": platform.python_implementation(),
            "platform": platform.platform(), "machine": platform.machine(), "processor": platform.processor() or None,
            "cpu_count": os.cpu_count()}


def header(policies: Iterable[Mapping[str, Any]], instances: Iterable[Mapping[str, Any]], *,
           split: str | None, workers: int, options: Mapping[str, Any], planned: Planned | None = None,
           threads: Mapping[str, Any] | None = None) -> dict[str, Any]:
    head = {"format": FORMAT, "agspec_version": __version__, "spec_version": SPEC_VERSION,
            "catalogue_digest": catalogue_digest(), "split": split, "command": sys.argv[1:], "workers": workers,
            "options": dict(options), "host": host_facts(),
            # F-POLICY-BUDGET: a trained policy's identity states the action it is evaluated with
            "policies": [with_action(p) for p in policies], "instances": list(instances)}
    if threads is not None:  # CAMP-THREADS: each policy process's intra-op threads, and the bound they meet
        head["threads"] = dict(threads)
    if planned is not None:  # F-POLICY-COVERAGE: what the summaries must be over
        head["planned"] = planned_entries(planned)
    return head


class BundleWriter:
    """Append episode records as they end; ``close`` writes the complete bundle."""

    def __init__(self, path: Path, head: Mapping[str, Any]):
        self.path = Path(path)
        self.head = dict(head)
        self.records: list[dict[str, Any]] = []
        self.fh = output.Stream(self.path)  # F-OUTPUT-FAILURES
        text = json.dumps(self.head, ensure_ascii=False)
        self.fh.write(text[:-1] + ', "episodes": [\n')

    def add(self, record: Mapping[str, Any]) -> None:
        self.fh.write(("" if not self.records else ",\n") + json.dumps(record, ensure_ascii=False))
        self.records.append(dict(record))

    def close(self, **tail: Any) -> None:
        """Rewrite the file complete (atomically) with ``tail`` fields such as wall time and findings."""
        self.fh.close()
        doc = {**self.head, "complete": True, **tail, "episodes": self.records}
        self_check("results", doc)  # F-SCHEMAS-SELF
        output.write_text(self.path, json.dumps(doc, indent=1, ensure_ascii=False) + "\n")

    def abandon(self) -> None:
        """Leave the incremental file as it is (interrupted campaign)."""
        self.fh.abandon()


def _recover(text: str) -> dict[str, Any] | None:
    """An interrupted bundle: keep the header and every whole episode line (the writer puts the
    header and each episode on a line of its own), read line by line — linear in the file."""
    head_line, _, rest = text.partition("\n")
    try:
        doc = limits.parse_json(head_line.rstrip() + "]}")
    except limits.InputError:
        return None
    if not isinstance(doc, dict) or not isinstance(doc.get("episodes"), list):
        return None
    for line in rest.split("\n"):
        line = line.strip().rstrip(",")
        if not line:
            continue
        try:
            record = limits.parse_json(line)
        except limits.InputError:
            break
        if not isinstance(record, dict):
            break
        doc["episodes"].append(record)
    doc["complete"] = False
    return doc


def read_bundle(path: str | Path) -> dict[str, Any]:
    """A results bundle, schema-checked; an interrupted one is recovered (``complete: false``).
    Read within the F-LIMITS limits (size, UTF-8, values, depth, duplicate keys)."""
    path = Path(path)
    try:
        text = limits.read_text(path)
    except limits.InputError as exc:
        raise BundleError(f"cannot read results bundle: {exc}") from None
    try:
        doc = limits.parse_json(text, str(path))
    except limits.InputError as exc:
        doc = _recover(text) if exc.code == "AG003" and text.startswith('{"format": "' + FORMAT) else None
        if doc is None:
            raise BundleError(f"not a results bundle: {exc}") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise BundleError(f"{path}: not a results bundle ({FORMAT})")
    problems = validate("results", doc, limit=1)
    if problems:
        raise BundleError(f"{path}{problems[0].pointer}: {problems[0].message}")
    return integers_of("results", doc)  # F-VALUES, RES-INTEGRAL-NUMBERS: an index of 2.0 is the index 2


def combine(bundles: list[tuple[str, Mapping[str, Any]]]) -> dict[str, Any]:
    """F-POLICY-BUNDLE: episodes, policies and instances of several bundles of one catalogue and spec."""
    if not bundles:
        raise BundleError("no results bundle given")
    first_name, first = bundles[0]
    for name, doc in bundles[1:]:
        for key, what in (("spec_version", "specification versions"), ("catalogue_digest", "catalogue digests")):
            if doc[key] != first[key]:
                raise BundleError(f"{name} and {first_name} have different {what} ({doc[key]} vs {first[key]}); "
                                  "results of different benchmarks cannot be compared")
    policies: dict[str, dict[str, Any]] = {}
    instances: dict[tuple[str, int], dict[str, Any]] = {}
    episodes: dict[tuple[str, str, int, bool], dict[str, Any]] = {}
    for name, doc in bundles:
        for p in map(with_action, doc["policies"]):  # an earlier bundle's checkpoint ran the masked argmax
            known = policies.get(p["label"])
            if known is not None and known != p:
                raise BundleError(f"{name}: policy label {p['label']!r} names another policy in an earlier bundle; "
                                  "re-run with --name to tell them apart")
            policies[p["label"]] = p
        for inst in doc["instances"]:
            key = (inst["scenario"], inst["index"])
            if key in instances and instances[key]["fingerprint"] != inst["fingerprint"]:
                raise BundleError(f"{name}: instance {key[0]}#{key[1]} has another fingerprint than in an earlier "
                                  "bundle")
            instances[key] = inst
        for ep in doc["episodes"]:
            episodes.setdefault((ep["controller"], ep["scenario"], ep["index"], bool(ep.get("repeat"))), ep)
    return {"spec_version": first["spec_version"], "catalogue_digest": first["catalogue_digest"],
            "agspec_version": first["agspec_version"], "policies": list(policies.values()),
            "planned": merge(*(planned_of_bundle(doc) for _, doc in bundles)),
            "split": first.get("split") if all(doc.get("split") == first.get("split") for _, doc in bundles) else None,
            "instances": list(instances.values()), "episodes": list(episodes.values()),
            "nondeterminism": [n for _, doc in bundles for n in doc.get("nondeterminism", [])],
            "complete": all(doc.get("complete", False) for _, doc in bundles)}
