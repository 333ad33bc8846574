"""The recipe view (spec chapter 02, RC-NAMES, RC-XOR): a tolerant index of a recipe IR, first
occurrence of every operation and XOR group id, that the recipe and material checks read."""

from __future__ import annotations

from dataclasses import dataclass

from agspec.ir.validate.common import Json, _dict, _list, _ptr, _str


@dataclass(frozen=True)
class _Op:
    index: int  # position in the IR list (pointers use it)
    id: str
    ir: dict

    @property
    def inputs(self) -> list[str]:
        return [t for t in _list(self.ir.get("inputs")) if isinstance(t, str)]

    @property
    def outputs(self) -> list[str]:
        return [t for t in _list(self.ir.get("outputs")) if isinstance(t, str)]

    @property
    def after(self) -> list[str]:
        return [p for p in _list(self.ir.get("after")) if isinstance(p, str)]

    def ptr(self, *parts: object) -> str:
        return _ptr("operations", self.index, *parts)


@dataclass(frozen=True)
class _RecipeView:
    id: str
    raw: tuple[str, ...]
    ops: tuple[_Op, ...]  # first occurrence of every id, IR order
    groups: dict[str, tuple[int, tuple[str, ...]]]  # group id -> (index, known distinct alternatives)
    group_of: dict[str, str]  # alternative -> its (first) group

    @property
    def op_ids(self) -> set[str]:
        return {op.id for op in self.ops}

    def op(self, op_id: str) -> _Op:
        return next(op for op in self.ops if op.id == op_id)


def recipe_view(ir: Json) -> _RecipeView:
    """A tolerant index of a recipe IR: first occurrence of every operation and group id."""
    ops: list[_Op] = []
    seen: set[str] = set()
    for k, op in enumerate(_list(_dict(ir).get("operations"))):
        oid = _str(_dict(op).get("id"))
        if oid is not None and oid not in seen:
            seen.add(oid)
            ops.append(_Op(k, oid, op))
    groups: dict[str, tuple[int, tuple[str, ...]]] = {}
    group_of: dict[str, str] = {}
    for g, group in enumerate(_list(_dict(ir).get("xor"))):
        gid = _str(_dict(group).get("id"))
        if gid is None or gid in groups or gid in seen:
            continue
        alts = []
        for alt in _list(_dict(group).get("alternatives")):
            if isinstance(alt, str) and alt in seen and alt not in group_of:
                group_of[alt] = gid
                alts.append(alt)
        groups[gid] = (g, tuple(alts))
    raw = tuple(dict.fromkeys(t for t in _list(_dict(ir).get("raw")) if isinstance(t, str)))
    return _RecipeView(str(_dict(ir).get("id")), raw, tuple(ops), groups, group_of)
