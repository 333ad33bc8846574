/* agspec trace viewer: the replay document's model — small helpers, the decoder of states (keyframes
 * plus per-tick diffs; applyDiff mirrors agspec/viewer/encode.py apply_diff) and the quantities derived
 * from a state. Spec IDs: G-DURATION (phases), F-TRACE-EVENTS (event vocabulary). */
const AgspecModel = (function () {
  "use strict";
  const SVGNS = "http://www.w3.org/2000/svg";
  const PALETTE = ["#e4572e", "#17bebb", "#7b2cbf", "#2e86ab", "#f18f01", "#3bb273", "#c1292e",
                   "#5c4d7d", "#d4a017", "#0f7173", "#ef476f", "#6a994e"];
  const DIRS = ["N", "NE", "E", "SE", "S", "SW", "W", "NW"];

  const clone = (v) => (v === null || typeof v !== "object") ? v : JSON.parse(JSON.stringify(v));
  function esc(s) {
    return String(s).replace(/[&<>"']/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" }[c]));
  }
  function el(name, attrs, parent) {
    const node = document.createElementNS(SVGNS, name);
    for (const k in attrs || {}) node.setAttribute(k, attrs[k]);
    if (parent) parent.appendChild(node);
    return node;
  }
  function hash(s) { let h = 2166136261; for (let i = 0; i < s.length; i++) { h ^= s.charCodeAt(i); h = Math.imul(h, 16777619); } return h >>> 0; }
  const colourOf = (id) => PALETTE[hash(String(id)) % PALETTE.length];
  const rc = (robot) => robot.split(",").map(Number);
  const candidateMembers = (cand) => { const p = String(cand).split(":"); return p[p.length - 1].split(";"); };
  const fmt = (x, d) => (x === null || x === undefined || Number.isNaN(x)) ? "–" : Number(x).toFixed(d);

  // ------------------------------------------------------------------ decoding (keyframes + diffs)
  function applyDiff(value, ops) {
    for (const op of ops) {
      const path = op[0];
      let parent = value;
      for (let i = 0; i < path.length - 1; i++) parent = parent[path[i]];
      const last = path[path.length - 1];
      if (op.length === 1) {
        if (Array.isArray(parent)) parent.length = last; else delete parent[last];
      } else {
        parent[last] = clone(op[1]); // appends when last === parent.length
      }
    }
    return value;
  }
  class Decoder {
    constructor(enc) { this.enc = enc; this.last = null; }
    at(i) {
      const enc = this.enc;
      if (!enc) return null;
      const K = enc.K, base = Math.floor(i / K) * K;
      let from = base, value;
      if (this.last && this.last.i <= i && this.last.i >= base) { from = this.last.i; value = clone(this.last.value); }
      else value = clone(enc.keys[Math.floor(i / K)]);
      for (let j = from + 1; j <= i; j++) applyDiff(value, enc.diffs[j]);
      this.last = { i: i, value: value };
      return clone(value);
    }
  }

  // ------------------------------------------------------------------ derived quantities
  function phaseOf(act, t) {
    // G-DURATION: D = A + P + R ticks from `start`; at state s_t, p = t - start ticks have elapsed.
    const A = act.approach || 0, P = act.process || 0, R = act.retreat || 0;
    const D = Math.max(1, (act.end != null && act.start != null) ? act.end - act.start : A + P + R);
    const p = Math.max(0, Math.min(D, t - act.start));
    let phase = "approach";
    if (p > A + P) phase = "retreat"; else if (p > A) phase = "process";
    if (A === 0 && p === 0) phase = P > 0 ? "process" : "retreat";
    // the tick inside the current phase and the phase's length: "process 2/4", not tick 8 of the whole D
    const k = phase === "approach" ? p : phase === "process" ? p - A : p - A - P;
    const n = phase === "approach" ? A : phase === "process" ? P : R;
    return { phase: phase, p: p, D: D, A: A, P: P, R: R, k: k, n: n };
  }
  function phaseText(ph) { return ph.phase + " " + ph.k + "/" + ph.n; }
  function phaseTitle(ph) {
    return "tick " + ph.p + " of " + ph.D + ": approach " + ph.A + " + process " + ph.P + " + retreat " + ph.R + " ticks (G-DURATION)";
  }
  function involvedRobots(ev) {
    const out = [];
    for (const k of ["robot", "sender", "receiver"]) if (typeof ev[k] === "string") out.push(ev[k]);
    if (typeof ev.candidate === "string" && ev.candidate.startsWith("op:")) out.push(...candidateMembers(ev.candidate));
    return out;
  }
  function describeEvent(ev) {
    const skip = new Set(["type"]);
    const parts = Object.keys(ev).filter((k) => !skip.has(k)).map((k) => k + "=" + (typeof ev[k] === "object" ? JSON.stringify(ev[k]) : ev[k]));
    return '<span class="mono ev-' + esc(ev.type) + '">' + esc(ev.type) + "(" + esc(parts.join(", ")) + ")</span>";
  }

  return { SVGNS: SVGNS, PALETTE: PALETTE, DIRS: DIRS, clone: clone, esc: esc, el: el, hash: hash, colourOf: colourOf, rc: rc, candidateMembers: candidateMembers, fmt: fmt, applyDiff: applyDiff, Decoder: Decoder, phaseOf: phaseOf, phaseText: phaseText, phaseTitle: phaseTitle, involvedRobots: involvedRobots, describeEvent: describeEvent };
})();
