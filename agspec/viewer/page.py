"""HTML assembly: one self-contained file (template + CSS + JS + the replay document as JSON).

The assets live in agspec/viewer/assets/ and are read with importlib.resources, so they ship in the
wheel (hatch packages ``agspec`` with its non-Python files). Nothing is fetched at view time.
"""

from __future__ import annotations

import html
import json
from importlib import resources
from typing import Any, Mapping

from agspec import __version__


def _asset(name: str) -> str:
    return resources.files("agspec.viewer").joinpath("assets", name).read_text(encoding="utf-8")


def embed_json(data: Any) -> str:
    """JSON safe inside <script type="application/json">: no `</`, no `<!--` can close or confuse it."""
    text = json.dumps(data, separators=(",", ":"), ensure_ascii=False, allow_nan=False)
    return text.replace("<", "\\u003c").replace("\u2028", "\\u2028").replace("\u2029", "\\u2029")


def build_page(data: Mapping[str, Any], *, title: str, mode: str) -> str:
    """The page for ``data`` ({"mode": "trace", "replay": doc} or the diff document)."""
    out = _asset("template.html")
    # substitute the data last: the JSON may contain any of the other markers as text
    for marker, value in (("__TITLE__", html.escape(title)), ("__MODE__", mode), ("__VERSION__", __version__),
                          ("__CSS__", _asset("viewer.css")),
                          ("__MODEL_JS__", _asset("model.js")),
                          ("__LAYOUT_JS__", _asset("layout.js")), ("__JS__", _asset("viewer.js"))):
        out = out.replace(marker, value)
    return out.replace("__DATA__", embed_json(data), 1)


__all__ = ["build_page", "embed_json"]
