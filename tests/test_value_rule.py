"""F-VALUES, RES-INTEGRAL-NUMBERS, RES-INTEGRAL-ACTIONS: one value rule for every reader, both directions.

The generator (tests/value_readers.py) re-spells every number of the documents each reader takes —
a policy's joint action, a process policy's replies, requests to ``agspec serve``, traces,
reproducers, results bundles — and asserts the verdict is unchanged; and puts ``2.5``, ``true``,
``"2"``, null and ``[2]`` where an action goes and asserts each reader refuses it, naming the place.
A bounded share runs here; benchmarks/fuzz_values.py runs the full set.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from agspec.formats.actions import IllegalAction, NotAnAction, action_value, resolve
from agspec.formats.values import MAX_SAFE_INTEGER, integer

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from value_readers import Readers, cases  # noqa: E402


@pytest.fixture(scope="module")
def readers(tmp_path_factory) -> Readers:
    return Readers(tmp_path_factory.mktemp("values"), HERE / "fakes")


def test_every_reader_keeps_its_verdict_and_refuses_what_is_not_an_action(readers):
    wrong = [(reader, label) for reader, label, ok in cases(readers, 6, seed=11) if not ok]
    assert wrong == []


@pytest.mark.parametrize("text, value", [("2", 2), ("2.0", 2), ("2e0", 2), ("20e-1", 2), ("113.000", 113),
                                         ("-0.0", 0), ("500.0", 500)])
def test_an_integral_number_is_the_action(text, value):
    got = action_value(json.loads(text))
    assert got == value and type(got) is int


@pytest.mark.parametrize("text", ["2.5", "true", "false", '"2"', "null", "[2]", "{}", "1e300"])
def test_anything_else_is_not_an_action(text):
    with pytest.raises(NotAnAction, match="RES-INTEGRAL-ACTIONS"):
        action_value(json.loads(text))


def test_numpy_scalars_are_their_value():
    assert action_value(np.int64(7)) == 7 and action_value(np.float32(7.0)) == 7
    with pytest.raises(NotAnAction):
        action_value(np.float64(7.5))


def test_the_integer_rule_is_the_shape_rule():  # one function: values.integer
    assert integer(float(MAX_SAFE_INTEGER)) == MAX_SAFE_INTEGER and integer(2.0**53) is None
    assert integer(True) is None and integer("3") is None


def test_a_script_action_follows_the_same_rule():  # F-SYMBOLIC-ACTIONS scripts
    assert resolve(3.0, [], []) == 3
    with pytest.raises(IllegalAction):
        resolve(3.5, [], [])
