"""F-VALUES: a number is its value; RES-INTEGRAL-NUMBERS and RES-INTEGRAL-ACTIONS: the one test of
whether a JSON value is an integer, which every reader that needs an integer calls.

``integer(v)`` is the integer ``v`` names — an ``int``, or a ``float`` with an integral value within
±(2^53 − 1) (``6.0``, ``6e0``, ``60E-1`` as a JSON decoder returns them) — or None: a boolean, a
fractional number, a string, anything else is not an integer.
"""

from __future__ import annotations

from typing import Any

# RES-NUMBER-RANGE: integers are exact within ±(2^53 − 1) in every JSON reader (I-JSON)
MAX_SAFE_INTEGER = 2**53 - 1


def integer(value: Any) -> int | None:
    """RES-INTEGRAL-NUMBERS: the integer ``value`` is (an integral number), else None."""
    tv = type(value)
    if tv is int:
        return value
    if tv is float and value.is_integer() and -MAX_SAFE_INTEGER <= value <= MAX_SAFE_INTEGER:
        return int(value)
    if tv is not bool and isinstance(value, int):  # an int subclass (not bool): its value
        return int(value)
    return None


__all__ = ["MAX_SAFE_INTEGER", "integer"]
