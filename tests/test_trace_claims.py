"""`agspec check` checks every claim of a trace header (F-TRACE-CLAIMS) and judges a file as
`agspec trace validate` does (F-TRACE-VALIDATE: one judgement).

* the two lies found by hand — a fingerprint one hex digit off, a stored instance edited (a pick
  duration 2 → 3) with the fingerprint kept or recomputed — fail `check` and `trace validate`
  alike, with the same codes;
* a bounded hypothesis run of the lying-header generator (tests/trace_claims.py) over honest traces
  written by `agspec run … --trace`: every mutant that changes a checkable claim fails, every
  mutant that changes nothing checkable passes; benchmarks/fuzz_trace_claims.py is the full run;
* the claims of a suite-indexed instance and of the controller, the spec version and the horizon.
"""

from __future__ import annotations

import copy
import json
from functools import lru_cache
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from agspec.cli.main import cli
from agspec.ir.fingerprint import fingerprint
from agspec.resources import conformance_dir
from trace_claims import expected_to_fail, judge, mutants, split, write

HORIZON = 6


@lru_cache(maxsize=None)
def honest(target: str, tmp: str) -> str:
    """The text of `agspec run TARGET --controller greedy --trace t.jsonl --horizon 6`."""
    path = Path(tmp) / (Path(target).stem + ".jsonl")
    result = CliRunner().invoke(cli, ["run", target, "--controller", "greedy", "--trace", str(path),
                                      "--horizon", str(HORIZON)])
    assert result.exit_code == 0, result.output
    return path.read_text(encoding="utf-8")


@pytest.fixture(scope="module")
def workdir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("claims")


SOURCES = ("flow-easy", "geometry-matched-low", str(conformance_dir() / "instances" / "solo-1x2-batch2-flat.json"))


def codes(command: list[str], path: Path) -> tuple[int, list[str]]:
    result = CliRunner().invoke(cli, [*command, str(path), "--format", "json"])
    data = json.loads(result.output)
    return result.exit_code, sorted(d["code"] for d in data.get("diagnostics", []))


def test_the_lies_found_by_hand_fail_check_and_validate_alike(workdir: Path) -> None:
    header, rest = split(honest("flow-easy", str(workdir)))
    fp = header["fingerprint"]
    off_by_one = copy.deepcopy(header)
    off_by_one["fingerprint"] = fp[:-1] + ("0" if fp[-1] != "0" else "1")
    edited = copy.deepcopy(header)
    edited["instance"]["profile"]["durations"]["pick"] = 3
    refingerprinted = copy.deepcopy(edited)
    refingerprinted["fingerprint"] = fingerprint(refingerprinted["instance"])
    for name, h, code in (("digit", off_by_one, "AG607"), ("edited", edited, "AG607"),
                          ("refingerprinted", refingerprinted, "AG513")):
        path = workdir / f"{name}.jsonl"
        write(path, h, rest)
        check_exit, check_codes = codes(["check"], path)
        validate_exit, validate_codes = codes(["trace", "validate"], path)
        assert check_exit == validate_exit == 1, name
        assert check_codes == validate_codes and code in check_codes, (name, check_codes, validate_codes)


@pytest.mark.parametrize("source", SOURCES)
def test_honest_traces_pass(workdir: Path, source: str) -> None:
    header, rest = split(honest(source, str(workdir)))
    assert judge(header, rest, workdir) == []


@lru_cache(maxsize=None)
def _all_mutants(source: str, tmp: str) -> list:
    header, _ = split(honest(source, tmp))
    return list(mutants(header))


@settings(max_examples=30, deadline=None, suppress_health_check=list(HealthCheck))
@given(data=st.data())
def test_lying_headers_fail_and_unchecked_changes_pass(workdir: Path, data: st.DataObject) -> None:
    source = data.draw(st.sampled_from(SOURCES))
    header, rest = split(honest(source, str(workdir)))
    ticks = sum(1 for line in rest if json.loads(line).get("type") == "tick")
    terminated = ticks < header["horizon"]
    pool = _all_mutants(source, str(workdir))
    m = data.draw(st.sampled_from(pool))
    want = expected_to_fail(m, header, terminated)
    problems = judge(m.header, rest, workdir)
    if want is True:
        assert problems, f"{m.label} passed `agspec check`"
    elif want is False:
        assert not problems, f"{m.label} changes nothing checkable, yet: {problems[:3]}"


def _header(workdir: Path, source: str = "flow-easy") -> tuple[dict, list[str]]:
    return split(honest(source, str(workdir)))


@pytest.mark.parametrize("edit, code, pointer", [
    (lambda h: h.update(spec_version="assemblygrid-v2"), "AG611", "/spec_version"),
    (lambda h: h.update(horizon=401), "AG611", "/horizon"),
    (lambda h: h["controller"].update(information="global"), "AG611", "/controller/information"),
    (lambda h: h["controller"].update(tuned=True), "AG204", "/controller/tuned"),
    (lambda h: h["instance"]["seeds"].update(index=1), "AG610", "/instance/seeds/generation"),
    (lambda h: h["instance"].update(id="ag32-flow-easy-s01"), "AG610", "/instance/id"),
    (lambda h: h["state"].update(lost_releases=1), "AG612", "/state/lost_releases"),
])
def test_each_header_claim_is_located(workdir: Path, edit, code: str, pointer: str) -> None:
    header, rest = _header(workdir)
    h = copy.deepcopy(header)
    edit(h)
    problems = judge(h, rest, workdir)
    assert any(p.startswith(f"{code} {pointer}") for p in problems), problems


def test_a_suite_index_claim_of_an_unofficial_scenario_is_checked(workdir: Path) -> None:
    header, rest = _header(workdir, "geometry-matched-low")
    h = copy.deepcopy(header)
    product = h["instance"]["realization"]["products"][1]
    lo, hi = h["instance"]["scenario"]["products"]["mass"]
    product["mass"] = (lo + hi) / 2 if product["mass"] != (lo + hi) / 2 else lo  # within range (AG513)
    h["fingerprint"] = fingerprint(h["instance"])
    assert any(p.startswith("AG610 /instance/realization/products/1") for p in judge(h, rest, workdir))
