"""Self-contained HTML replays of traces and conformance divergences (``agspec render``).

Data flows one way: ``encode`` turns trace records (F-TRACE) into the compact replay document
(keyframes + per-tick diffs, documented in docs/viewer.md), ``divergence`` rebuilds the two sides of
a conformance failure (F-REPORT, F-REPRO), ``record`` drives any implementation over the protocol
(F-PROTOCOL) into a trace, and ``page`` inlines the document, JS and CSS into one HTML file.
Nothing here changes the interpreter or the harness; the viewer only reads their outputs.
"""
