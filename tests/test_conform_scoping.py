"""One item's failure does not decide the others (F-PROTOCOL "giving up", CAMP-FAULTS).

The generator: simulators of tests/fakes/scripted_sim.py that fail on some instances — an
``ok: false`` answer to load or reset, a crash at load or at a step, a line that is not JSON — run
over items on several instances, some of which they handle correctly.  The property: every item on
a correctly handled instance passes, whatever failed before it; every failing item reports its own
cause; the harness gives up only on the instance that failed (``max_restarts`` times), never on
items that did not fail; a refusal of load or reset points to ``unsupported``.
"""

from __future__ import annotations

import json
import shlex
import sys

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from agspec.conform import runner
from agspec.conform.cases import load_suite
from agspec.conform.impl import SubprocessImpl
from agspec.conform.items import catalogue_episodes, from_case
from agspec.conform.run_item import DECLINE_HINT
from agspec.formats.protocol import ProtocolError
from scoping_cases import NAMES, scripted, small_items


def test_the_original_release_refusing_custom_instances_keeps_the_catalogue_episodes():
    """Eleven refusals (`invalid_instance`) no longer cost a restart each, so the run never gives up and
    the catalogue episodes that pass on their own are reported as passing."""
    custom = [from_case(c) for c in load_suite() if not c.instance["id"].startswith("ag32-")]
    custom = [item for item in custom if not item.case.needs_observations][:12]
    items = custom + catalogue_episodes(1, 3, ["flow-easy", "coalition-easy"])
    impl = SubprocessImpl(scripted("--refuse-custom", "invalid_instance"), 15.0)
    try:
        summary = runner.run(items, "original", impl=impl, replays=0)
    finally:
        impl.close()
    outcomes = [o for _, o in summary.results]
    assert outcomes[:12] == ["error"] * 12 and outcomes[12:] == ["pass", "pass"]
    assert impl.restarts == 0  # an answer, even `ok: false`, leaves the simulator running
    first = summary.results[0][0]
    assert first.failure["code"] == "error_reply" and DECLINE_HINT in first.message and "unsupported" in first.message
    assert summary.exit_code == 3  # errors remain errors: declining is `unsupported`, as the hint says


MODES = st.sampled_from([None, None, ("load", "error:invalid_instance"), ("reset", "error:bad_seed"),
                         ("load", "crash"), ("step", "crash"), ("step", "garbage")])


@settings(max_examples=4, deadline=None, database=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(st.tuples(MODES, MODES, MODES))
def test_failures_are_scoped_to_their_instance(modes):
    plan = {name: {"cmd": m[0], "mode": m[1], "at": 1} for name, m in zip(NAMES, modes) if m}
    items = small_items(repeat=3)  # each instance three times: the third is past max_restarts
    impl = SubprocessImpl(scripted("--fail", json.dumps(plan)), 15.0, max_restarts=2)
    try:
        summary = runner.run(items, "scripted", impl=impl, replays=0)
    finally:
        impl.close()
    assert len(summary.results) == len(items)
    for result, outcome in summary.results:
        name = result.item.title
        mode = plan.get(name)
        if mode is None:
            assert outcome == "pass", (name, result.message)
            continue
        assert outcome == "error", (name, result.message)
        code = result.failure["code"]
        restarts = not mode["mode"].startswith("error:")
        earlier = int(result.item.id.rsplit("-", 1)[1])  # failures of this instance before this item
        if restarts and earlier >= 2:
            assert code == "gave_up" and name in result.message and "other instances still run" in result.message
        else:
            want = {"error": "error_reply", "crash": "exit", "garbage": "malformed_json"}[mode["mode"].split(":")[0]]
            assert code == want, (name, mode, result.message)


def test_a_simulator_that_never_starts_is_given_up_after_max_restarts():
    """The one scope every item shares: no item runs without a started simulator."""
    impl = SubprocessImpl(shlex.join([sys.executable, "-c", "import sys; sys.exit(7)"]), 15.0, max_restarts=2)
    codes = []
    for _ in range(3):
        with pytest.raises(ProtocolError) as err:
            impl.start()
        codes.append(err.value.code)
    impl.close()
    assert codes == ["exit", "exit", "gave_up"]
    assert "failed to start 2 times in a row" in err.value.message
