"""F-FINGERPRINT: canonical bytes and fingerprints of IR documents."""

from __future__ import annotations

import copy
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agspec.ir.fingerprint import FingerprintError, canonical_bytes, defining_view, fingerprint
from agspec.ir.instance import make_instance
from conftest_ir import bundle, official_ir

TESTS = Path(__file__).resolve().parent


def _instance(name: str = "coalition-medium", index: int = 0) -> dict[str, Any]:
    return make_instance(*bundle(name), index=index)


def _reorder(value: Any) -> Any:
    """Same JSON value with every object's keys in reverse order."""
    if isinstance(value, dict):
        return {k: _reorder(value[k]) for k in reversed(list(value))}
    if isinstance(value, list):
        return [_reorder(v) for v in value]
    return value


def _leaves(value: Any, path: tuple = ()) -> list[tuple]:
    if isinstance(value, dict):
        return [leaf for k, v in value.items() for leaf in _leaves(v, path + (k,))]
    if isinstance(value, list):
        return [leaf for i, v in enumerate(value) for leaf in _leaves(v, path + (i,))]
    return [path]


def _non_defining(ir: dict[str, Any], path: tuple) -> bool:
    if path and path[0] in ("id", "meta"):
        return True
    if "doc" in path:
        return True
    return ir.get("kind") == "instance" and path[:2] in (("seeds", "execution"), ("seeds", "index"))


def _mutate(value: Any) -> Any:
    if isinstance(value, bool):
        return not value
    if isinstance(value, int):
        return value + 1
    if isinstance(value, float):
        return value + 0.5
    if isinstance(value, str):
        return value + "x"
    if value is None:
        return 0
    raise AssertionError(value)


def _set(doc: Any, path: tuple, new: Any) -> None:
    for key in path[:-1]:
        doc = doc[key]
    doc[path[-1]] = new


def _get(doc: Any, path: tuple) -> Any:
    for key in path:
        doc = doc[key]
    return doc


def test_format_is_sha256_prefixed_hex():
    fp = fingerprint(official_ir()["scenarios"]["flow-easy"])
    assert fp.startswith("sha256:") and len(fp) == 7 + 64
    int(fp[7:], 16)


def test_canonical_bytes_are_rfc8785_of_the_defining_part():
    doc = {"kind": "x", "id": "name", "meta": {"a": 1}, "doc": "text", "b": 1.0,
           "a": [1, "é", {"doc": "t", "z": 0.5}]}
    assert canonical_bytes(doc) == '{"a":[1,"é",{"z":0.5}],"b":1,"kind":"x"}'.encode("utf-8")


def test_stable_across_processes():
    """The same IR fingerprints identically in a fresh interpreter with another hash seed."""
    ir = _instance("flow-hard", 1000)
    code = (
        "import sys; sys.path.insert(0, sys.argv[1]);"
        "from conftest_ir import bundle; from agspec.ir.instance import make_instance;"
        "from agspec.ir.fingerprint import fingerprint;"
        "print(fingerprint(make_instance(*bundle('flow-hard'), index=1000)))"
    )
    env = {**os.environ, "PYTHONHASHSEED": "12345"}
    out = subprocess.run([sys.executable, "-c", code, str(TESTS)], capture_output=True, text=True,
                         env=env, check=True)
    assert out.stdout.strip() == fingerprint(ir)


def test_insensitive_to_key_order_and_whitespace():
    ir = _instance()
    text = json.dumps(_reorder(ir), indent=7, separators=(" ,  ", " :   "))
    assert fingerprint(json.loads(text)) == fingerprint(ir)
    assert canonical_bytes(_reorder(ir)) == canonical_bytes(ir)


def test_insensitive_to_doc_id_and_meta():
    ir = official_ir()
    recipe = ir["recipes"]["supported_insert"]
    base = fingerprint(recipe)
    edited = copy.deepcopy(recipe)
    edited["doc"] = "a supported insertion"
    edited["operations"][0]["doc"] = "align A and B"
    edited["id"] = "renamed"
    edited["meta"] = {"source": "catalogue/recipes/supported_insert.ag"}
    assert fingerprint(edited) == base


def test_int_and_float_spellings_are_the_same_number():
    scenario = official_ir()["scenarios"]["coalition-easy"]
    edited = copy.deepcopy(scenario)
    edited["products"]["mass"] = [0.5, 2]  # 2 == 2.0 in RFC 8785
    assert fingerprint(edited) == fingerprint(scenario)


def test_instance_ignores_execution_seed_but_not_generation_seed():
    sc, rc, pr = bundle("coalition-medium")
    a = make_instance(sc, rc, pr, index=3)
    b = make_instance(sc, rc, pr, index=3, execution_seed=999)
    assert a["seeds"]["execution"] != b["seeds"]["execution"]
    assert fingerprint(a) == fingerprint(b)
    c = copy.deepcopy(a)
    c["seeds"]["generation"] += 1
    assert fingerprint(c) != fingerprint(a)


def test_index_is_a_label_but_the_generation_seed_is_defining():
    """F-FINGERPRINT: index k and its generation seed give the same problem, hence one fingerprint."""
    sc, rc, pr = bundle("coalition-medium")
    by_index = make_instance(sc, rc, pr, index=3)
    by_seed = make_instance(sc, rc, pr, generation_seed=by_index["seeds"]["generation"],
                            execution_seed=by_index["seeds"]["execution"])
    assert by_index["seeds"]["index"] == 3 and by_seed["seeds"]["index"] is None
    assert fingerprint(by_index) == fingerprint(by_seed)


def test_resource_named_doc_stays_defining():
    base = {"kind": "scenario", "resources": {"doc": 1}}
    assert fingerprint(base) != fingerprint({"kind": "scenario", "resources": {"doc": 2}})
    assert fingerprint({"kind": "scenario", "doc": "a"}) == fingerprint({"kind": "scenario", "doc": "b"})


def test_execution_key_is_defining_outside_instances():
    doc = {"kind": "scenario", "seeds": {"execution": 1}}
    assert defining_view(doc) == doc
    assert fingerprint(doc) != fingerprint({"kind": "scenario", "seeds": {"execution": 2}})


def test_order_meaningful_lists_matter():
    recipe = official_ir()["recipes"]["supported_insert"]
    swapped = copy.deepcopy(recipe)
    swapped["raw"] = ["B", "A"]
    assert fingerprint(swapped) != fingerprint(recipe)


def test_uncanonicalisable_values_are_reported():
    with pytest.raises(FingerprintError):
        fingerprint({"kind": "x", "v": float("nan")})
    with pytest.raises(FingerprintError):
        fingerprint({"kind": "x", "v": 2**60})
    with pytest.raises(FingerprintError):
        fingerprint(["not", "an", "object"])  # type: ignore[arg-type]


_DOCS = {
    "scenario": official_ir()["scenarios"]["coalition-medium"],
    "recipe": official_ir()["recipes"]["standard_abc"],
    "profile": official_ir()["profiles"]["abstract-v1"],
    "instance": _instance("concurrency-easy", 2),
}
_LEAVES = [(kind, path) for kind, doc in _DOCS.items() for path in _leaves(doc)
           if not _non_defining(doc, path)]


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(_LEAVES))
def test_every_defining_leaf_changes_the_fingerprint(leaf):
    kind, path = leaf
    doc = copy.deepcopy(_DOCS[kind])
    before = fingerprint(doc)
    _set(doc, path, _mutate(_get(doc, path)))
    assert fingerprint(doc) != before, path


@settings(max_examples=100, deadline=None)
@given(st.sampled_from([(k, p) for k, d in _DOCS.items() for p in _leaves(d) if _non_defining(d, p)]))
def test_non_defining_leaves_do_not_change_the_fingerprint(leaf):
    kind, path = leaf
    doc = copy.deepcopy(_DOCS[kind])
    before = fingerprint(doc)
    _set(doc, path, _mutate(_get(doc, path)))
    assert fingerprint(doc) == before, path
