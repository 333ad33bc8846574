/* agspec trace viewer: replays an agspec-replay/1 document (docs/viewer.md) in inline SVG.
 * No network, no dependencies. States are rebuilt from the nearest keyframe plus per-tick diffs
 * (applyDiff mirrors agspec/viewer/encode.py apply_diff). Spec IDs: O-GLOBAL-STATE (state fields),
 * G-BASE / RES-SHELF-POINT / G-OUTPUT-POINT (layout), G-DURATION (phases), O-SUPPORT-FRACTION,
 * F-TRACE-EVENTS (event vocabulary), O-ACTION-ENCODING (mask slots). */
(function () {
  "use strict";
  const DATA = JSON.parse(document.getElementById("replay-data").textContent);
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

  // ------------------------------------------------------------------ one grid pane
  class Pane {
    constructor(container, doc, label, id) {
      this.doc = doc;
      this.states = new Decoder(doc.states);
      this.obs = new Decoder(doc.observations);
      const L = doc.layout;
      this.rows = L.grid.rows; this.cols = L.grid.cols;
      this.s = Number(L.profile.spacing) || 1; this.reach = Number(L.profile.reach) || 1.5;
      this.S = 72 / this.s; // pixels per task-space unit: one cell is 72 px whatever the spacing
      this.x0 = 1.35 * this.s; this.y0 = 0.75 * this.s;
      const wrap = document.createElement("div");
      wrap.className = "pane"; if (id) wrap.id = id;
      if (label) { const h = document.createElement("h3"); h.textContent = label; wrap.appendChild(h); }
      container.appendChild(wrap);
      const W = this.cols * this.s + this.x0 + 0.55 * this.s, H = (this.rows - 1) * this.s + 2 * this.y0;
      this.svg = el("svg", { viewBox: "0 0 " + (W * this.S).toFixed(1) + " " + (H * this.S).toFixed(1), role: "img" }, wrap);
      this.layers = {};
      for (const name of ["static", "reach", "props", "acts", "robots", "items", "labels"]) this.layers[name] = el("g", { class: "layer-" + name }, this.svg);
      this.robotEls = {};
      this.itemEls = {};
      this.buildStatic();
    }
    X(x) { return ((x + this.x0) * this.S).toFixed(1); }
    Y(y) { return ((y + this.y0) * this.S).toFixed(1); }
    base(robot) { const [i, j] = rc(robot); return [j * this.s, i * this.s]; } // G-BASE
    buildStatic() {
      const g = this.layers.static, s = this.s, S = this.S, L = this.doc.layout;
      // shelves (RES-SHELF-POINT: pick target (-s/2, r s)), one per row
      this.shelfEls = [];
      for (let r = 0; r < this.rows; r++) {
        const sg = el("g", { class: "shelf", "data-shelf": r }, g);
        el("rect", { x: this.X(-1.25 * s), y: this.Y(r * s - 0.32 * s), width: (0.62 * s * S).toFixed(1), height: (0.64 * s * S).toFixed(1), rx: 4 }, sg);
        el("circle", { cx: this.X(-0.5 * s), cy: this.Y(r * s), r: 2.5, fill: "#c9a227" }, sg);
        const tx = el("text", { x: this.X(-1.2 * s), y: this.Y(r * s - 0.14 * s) }, sg);
        tx.textContent = "shelf " + r;
        this.shelfEls.push(el("text", { x: this.X(-1.2 * s), y: this.Y(r * s + 0.12 * s), "font-weight": 600 }, sg));
      }
      // output points (G-OUTPUT-POINT: (N s, i s))
      for (let r = 0; r < this.rows; r++) {
        const og = el("g", { class: "outbox" }, g);
        el("rect", { x: this.X(this.cols * s - 0.08 * s), y: this.Y(r * s - 0.25 * s), width: (0.5 * s * S).toFixed(1), height: (0.5 * s * S).toFixed(1), rx: 4 }, og);
        el("circle", { cx: this.X(this.cols * s), cy: this.Y(r * s), r: 2.5, fill: "#34a853" }, og);
        el("text", { x: this.X(this.cols * s + 0.06 * s), y: this.Y(r * s + 0.05 * s) }, og).textContent = "out";
      }
      // reach disks, on demand
      for (let i = 0; i < this.rows; i++) for (let j = 0; j < this.cols; j++)
        el("circle", { class: "reach", cx: this.X(j * s), cy: this.Y(i * s), r: (this.reach * S).toFixed(1) }, this.layers.reach);
      this.layers.reach.style.display = "none";
      // the selected robot's reach disk is always shown
      this.selReach = el("circle", { class: "reach-selected", r: (this.reach * S).toFixed(1), cx: -1000, cy: -1000 }, this.layers.props.parentNode.insertBefore(el("g", {}), this.layers.props));
      // robots
      const half = 0.36 * s;
      for (let i = 0; i < this.rows; i++) for (let j = 0; j < this.cols; j++) {
        const id = i + "," + j;
        const rg = el("g", { class: "robot", "data-robot": id, "data-coalition": "", "data-role": "", tabindex: 0 }, this.layers.robots);
        const cell = el("rect", { class: "cell", x: this.X(j * s - half), y: this.Y(i * s - half), width: (2 * half * S).toFixed(1), height: (2 * half * S).toFixed(1), rx: 7 }, rg);
        el("rect", { class: "blocked-ring", x: this.X(j * s - half - 0.04 * s), y: this.Y(i * s - half - 0.04 * s), width: ((2 * half + 0.08 * s) * S).toFixed(1), height: ((2 * half + 0.08 * s) * S).toFixed(1), rx: 9 }, rg);
        el("rect", { class: "diff-ring", x: this.X(j * s - half - 0.08 * s), y: this.Y(i * s - half - 0.08 * s), width: ((2 * half + 0.16 * s) * S).toFixed(1), height: ((2 * half + 0.16 * s) * S).toFixed(1), rx: 11 }, rg);
        const inc = el("circle", { class: "incoming", cx: this.X(j * s), cy: this.Y(i * s), r: (0.28 * s * S).toFixed(1) }, rg);
        const rid = el("text", { class: "rid", x: this.X(j * s - half + 0.05 * s), y: this.Y(i * s - half + 0.16 * s) }, rg);
        rid.textContent = id;
        const role = el("text", { class: "role", x: this.X(j * s), y: this.Y(i * s + 0.06 * s), "text-anchor": "middle" }, rg);
        const phase = el("text", { class: "phase", x: this.X(j * s), y: this.Y(i * s + half - 0.07 * s), "text-anchor": "middle" }, rg);
        const phaseTitleEl = el("title", {}, phase);
        const title = el("title", {}, rg);
        rg.addEventListener("click", () => viewer.select(id));
        this.robotEls[id] = { g: rg, cell: cell, role: role, phase: phase, phaseTitle: phaseTitleEl, incoming: inc, title: title };
      }
    }
    render(t, highlight) {
      const st = this.states.at(Math.min(t, this.doc.T));
      const events = this.doc.events[Math.min(t, this.doc.T)] || [];
      this.state = st; this.t = t; this.events = events;
      const s = this.s, S = this.S;
      // shelves stock
      (st.shelves || []).forEach((stock, r) => {
        if (this.shelfEls[r]) this.shelfEls[r].textContent = Object.keys(stock || {}).map((k) => k + "×" + stock[k]).join(" ");
      });
      // activities: colours, roles, phases
      const actOf = {};
      (st.activities || []).forEach((a) => (a.members || []).forEach((m) => { actOf[m] = a; }));
      const blocked = {};
      for (const ev of events) if (ev.type === "blocked" || ev.type === "admission_failed") for (const r of involvedRobots(ev)) blocked[r] = ev;
      const hl = highlight || { robots: new Set(), items: new Set() };
      let busy = 0;
      for (const id in this.robotEls) {
        const R = this.robotEls[id], rb = (st.robots || {})[id] || {}, a = actOf[id];
        const cls = ["robot"];
        R.g.setAttribute("data-coalition", "");
        R.g.setAttribute("data-role", "");
        R.g.setAttribute("data-phase", "");
        R.cell.style.fill = ""; R.cell.style.stroke = "";
        R.role.textContent = ""; R.phase.textContent = ""; R.role.style.fill = "";
        R.phase.appendChild(R.phaseTitle); R.phaseTitle.textContent = "";
        if (rb.activity) busy++;
        if (a) {
          const ph = phaseOf(a, st.t);
          R.g.setAttribute("data-phase", ph.phase);
          R.g.setAttribute("data-activity", a.id);
          R.phase.textContent = phaseText(ph);
          R.phase.appendChild(R.phaseTitle);
          R.phaseTitle.textContent = phaseTitle(ph);
          if (a.kind === "operation") {
            const c = colourOf(a.id);
            cls.push("coalition");
            R.g.setAttribute("data-coalition", a.id);
            R.g.setAttribute("data-coalition-size", String((a.members || []).length));
            const role = (a.roles || {})[id] || "";
            R.g.setAttribute("data-role", role);
            R.role.textContent = role;
            R.role.style.fill = c;
            R.cell.style.fill = c + "33"; R.cell.style.stroke = c;
          } else {
            cls.push("logistics");
            R.role.textContent = a.kind;
          }
        } else R.g.removeAttribute("data-activity");
        if (blocked[id]) { cls.push("blocked"); R.g.setAttribute("data-blocked", blocked[id].cause || blocked[id].reason || blocked[id].type); }
        else R.g.removeAttribute("data-blocked");
        if (hl.robots.has(id)) cls.push("diff");
        if (viewer.selected === id) cls.push("selected");
        R.g.setAttribute("class", cls.join(" "));
        R.incoming.style.display = rb.incoming ? "" : "none";
        R.title.textContent = id + (rb.holding ? " holding " + rb.holding : "") + (a ? " · " + a.id : "") + (rb.supports ? " · supports " + rb.supports : "");
      }
      this.busy = busy;
      if (viewer.selected && this.robotEls[viewer.selected]) {
        const [bx, by] = this.base(viewer.selected);
        this.selReach.setAttribute("cx", this.X(bx)); this.selReach.setAttribute("cy", this.Y(by));
        this.selReach.style.display = "";
      } else this.selReach.style.display = "none";
      this.renderActs(st, blocked, events);
      this.renderItems(st, hl);
    }
    renderActs(st, blocked, events) {
      const g = this.layers.acts, lab = this.layers.labels, pg = this.layers.props, s = this.s, S = this.S;
      g.textContent = ""; lab.textContent = ""; pg.textContent = "";
      // end effectors and arms (G-END-EFFECTOR)
      for (const id in st.robots || {}) {
        const rb = st.robots[id], [bx, by] = this.base(id);
        if (!Array.isArray(rb.ee)) continue;
        const [ex, ey] = rb.ee;
        if (Math.hypot(ex - bx, ey - by) > 1e-9) el("line", { class: "arm", x1: this.X(bx), y1: this.Y(by), x2: this.X(ex), y2: this.Y(ey) }, g);
        el("circle", { class: "ee", cx: this.X(ex), cy: this.Y(ey), r: 3 }, g);
      }
      // activities: member -> common target, coloured per coalition
      for (const a of st.activities || []) {
        const op = a.kind === "operation", c = op ? colourOf(a.id) : "#7fa7d6";
        const tgt = Array.isArray(a.target) ? a.target : null;
        for (const m of a.members || []) {
          if (!tgt) continue;
          const [bx, by] = this.base(m);
          el("line", { class: "act-line" + (op ? "" : " logistics"), stroke: c, x1: this.X(bx), y1: this.Y(by), x2: this.X(tgt[0]), y2: this.Y(tgt[1]) }, g);
        }
        if (tgt) {
          if (op) {
            const x = +this.X(tgt[0]), y = +this.Y(tgt[1]), r = (a.members || []).length > 1 ? 7 : 5;
            el("polygon", { class: "target", fill: c, points: [[x, y - r], [x + r, y], [x, y + r], [x - r, y]].map((p) => p.join(",")).join(" ") }, g);
            if ((a.members || []).length > 1) { // a singleton's role and phase are in its cell already
              const tx = el("text", { class: "proposal-label", x: x + 9, y: y - 6, style: "fill:" + c }, lab);
              tx.textContent = (a.operation || "op") + " · " + phaseOf(a, st.t).phase;
            }
          } else el("circle", { class: "target", fill: c, cx: this.X(tgt[0]), cy: this.Y(tgt[1]), r: 3.5 }, g);
        }
      }
      // pending supports (support records, O-SUPPORT-FRACTION)
      for (const cand in st.proposals || {}) {
        const pr = st.proposals[cand], members = candidateMembers(cand);
        const sup = (pr.supporters || []).length;
        const pts = members.map((m) => this.base(m));
        const cx = pts.reduce((a, p) => a + p[0], 0) / pts.length, cy = pts.reduce((a, p) => a + p[1], 0) / pts.length;
        if (pts.length >= 2) el("polyline", { class: "proposal", points: pts.concat(pts.length > 2 ? [pts[0]] : []).map((p) => this.X(p[0]) + "," + this.Y(p[1])).join(" ") }, pg);
        else el("circle", { class: "proposal", cx: this.X(cx), cy: this.Y(cy), r: (0.3 * s * S).toFixed(1) }, pg);
        const tx = el("text", { class: "proposal-label", x: this.X(cx), y: +this.Y(cy) + 4, "text-anchor": "middle" }, lab);
        tx.textContent = "support " + sup + "/" + members.length;
      }
      // blocked attempts, flashed with their cause (R-BLOCKING)
      const seen = new Set();
      for (const ev of events) {
        if (ev.type !== "blocked" && ev.type !== "admission_failed") continue;
        const rs = involvedRobots(ev).filter((r) => (st.robots || {})[r]);
        if (!rs.length) continue;
        const key = rs[0];
        if (seen.has(key)) continue; seen.add(key);
        const [bx, by] = this.base(key);
        const tx = el("text", { class: "blocked-label", x: this.X(bx), y: +this.Y(by + 0.5 * s) + 2, "text-anchor": "middle" }, lab);
        tx.textContent = ev.type === "blocked" ? "blocked: " + ev.cause + " (" + ev.kind + ")" : "admission failed: " + ev.reason;
      }
    }
    renderItems(st, hl) {
      // drawn from the robots' `holding` (so a duplicated item shows twice); `items` (item -> holder)
      // should agree — an item whose map entry names another holder is drawn with a warning outline
      const items = st.items || {}, seen = new Set(), stack = {};
      const held = [];
      for (const id in st.robots || {}) { const h = st.robots[id].holding; if (h !== null && h !== undefined) held.push([String(h), id]); }
      for (const item in items) if (!held.some((x) => x[0] === item && x[1] === items[item]) && (st.robots || {})[items[item]]) held.push([item, items[item]]);
      const copies = {}, placed = [];
      for (const [item, holder] of held) {
        // keyed by item (a second copy gets "#2"), so an item changing holder moves (CSS transition)
        copies[item] = (copies[item] || 0) + 1;
        const rb = st.robots[holder], key = copies[item] > 1 ? item + "#" + copies[item] : item;
        seen.add(key);
        const n = stack[holder] = (stack[holder] || 0) + 1;
        const p = Array.isArray(rb.ee) ? rb.ee : this.base(holder);
        let node = this.itemEls[key];
        if (!node) {
          // the whole id, in a label as wide as its text (9 px bold: about 6 px a character)
          const w = Math.max(24, 6 * item.length + 8);
          node = el("g", { class: "item", "data-item": item }, this.layers.items);
          el("line", { class: "leader", x1: 0, y1: 0, x2: 0, y2: 0 }, node);
          el("rect", { x: -w / 2, y: -7.5, width: w, height: 15, rx: 3 }, node);
          el("text", { x: 0, y: 3, "text-anchor": "middle" }, node).textContent = item;
          el("title", {}, node);
          node.labelWidth = w;
          this.itemEls[key] = node;
        }
        const consistent = items[item] === holder && rb.holding === item;
        node.setAttribute("data-holder", holder);
        node.lastChild.textContent = "item " + item + " held by " + holder + (consistent ? "" : " (state.items says " + (items[item] || "nothing") + ")");
        node.setAttribute("class", "item" + (hl.items.has(item) || hl.robots.has(holder) ? " diff" : "") + (consistent ? "" : " inconsistent"));
        // in the gap below the holder's cell (cells span ±0.36 s around the base, G-BASE), so a label
        // never covers a robot; a leader line points at the end effector that holds it (G-END-EFFECTOR)
        const [bx, by] = this.base(holder);
        placed.push({ node: node, x: +this.X(bx), y: +this.Y(by + 0.5 * this.s) + (n - 1) * 16,
                      ex: +this.X(p[0]), ey: +this.Y(p[1]), w: node.labelWidth });
      }
      // on dense grids end-effectors converge on one site: move a label down until it overlaps no other
      // (labels are 32 x 15 px, centred on their anchor), in a stable order so frames do not jitter
      placed.sort((a, b) => a.y - b.y || a.x - b.x);
      const boxes = [];
      for (const q of placed) {
        while (boxes.some((b) => Math.abs(b.x - q.x) < (b.w + q.w) / 2 + 1 && Math.abs(b.y - q.y) < 16)) q.y += 16;
        boxes.push(q);
        q.node.style.transform = "translate(" + q.x + "px," + q.y + "px)";
        const leader = q.node.firstChild;
        leader.setAttribute("x2", (q.ex - q.x).toFixed(1)); leader.setAttribute("y2", (q.ey - q.y).toFixed(1));
      }
      for (const key in this.itemEls) if (!seen.has(key)) { this.itemEls[key].remove(); delete this.itemEls[key]; }
    }
    showReach(on) { this.layers.reach.style.display = on ? "" : "none"; }
    showIds(on) { this.svg.querySelectorAll(".rid").forEach((n) => { n.style.display = on ? "" : "none"; }); }
  }

  // ------------------------------------------------------------------ side panels
  function activitiesHtml(st) {
    const acts = st.activities || [];
    if (!acts.length) return '<div class="empty">none</div>';
    return acts.map((a) => {
      const ph = phaseOf(a, st.t), op = a.kind === "operation";
      const c = op ? colourOf(a.id) : "#7fa7d6";
      const roles = op ? Object.keys(a.roles || {}).map((m) => m + "=" + a.roles[m]).join(", ") : (a.item || "");
      const w = (x) => (100 * x / ph.D).toFixed(1) + "%";
      return '<div class="row" data-activity-row="' + esc(a.id) + '"><span class="swatch" style="background:' + c + '"></span><b>' +
        esc(op ? a.operation : a.kind) + "</b> " + (a.product != null ? "product " + esc(a.product) + " · " : "") + esc((a.members || []).join(" ")) +
        '<div class="mono">' + esc(roles) + '</div><div class="phasebar" title="approach ' + ph.A + " · process " + ph.P + " · retreat " + ph.R + ' (G-DURATION)">' +
        '<div class="ap" style="width:' + w(ph.A) + '"></div><div class="pr" style="width:' + w(ph.P) + '"></div><div class="re" style="width:' + w(ph.R) + '"></div>' +
        '<div class="now" style="left:' + w(ph.p) + '"></div></div><span class="hint">' + phaseText(ph) + " · activity tick " + ph.p + "/" + ph.D +
        " (approach " + ph.A + " + process " + ph.P + " + retreat " + ph.R + ") · t " + a.start + "→" + a.end + "</span></div>";
    }).join("");
  }
  function proposalsHtml(st) {
    const ps = Object.keys(st.proposals || {});
    if (!ps.length) return '<div class="empty">none</div>';
    return ps.map((cand) => {
      const pr = st.proposals[cand], m = candidateMembers(cand), k = (pr.supporters || []).length;
      return '<div class="row"><span class="mono">' + esc(cand) + "</span><br>support " + k + "/" + m.length + " = " + (100 * k / m.length).toFixed(0) +
        "% · supporters " + esc((pr.supporters || []).join(" ") || "–") + " · created " + esc(pr.created_at) + " · expires " + esc(pr.expires_at) + "</div>";
    }).join("");
  }
  function eventsHtml(events, t) {
    if (!events || !events.length) return '<div class="empty">none</div>';
    return '<div class="hint">' + (t === 0 ? "reset events" : "transition " + (t - 1) + " → " + t) + "</div>" +
      events.map((ev) => '<div class="row">' + describeEvent(ev) + "</div>").join("");
  }
  function itemText(h) {
    return (h && typeof h === "object") ? (h.product !== undefined ? h.product + ":" + h.token + (h.final ? " final" : "") : JSON.stringify(h)) : String(h);
  }
  function slotLabel(a, ob) {
    if (a === 0) return "0 idle";
    if (a === 1) return "1 deliver";
    if (a < 34) { const o = (ob && ob.pick_options || [])[a - 2]; return a + " pick slot " + (a - 2) + (o ? " " + JSON.stringify(o) : ""); }
    if (a < 42) return a + " handoff " + DIRS[a - 34];
    if (a < 50) return a + " receive " + DIRS[a - 42];
    const o = (ob && ob.operation_options || [])[a - 50];
    return a + " support slot " + (a - 50) + (o ? " " + JSON.stringify(o) : "");
  }
  function robotHtml(pane, id, t) {
    const st = pane.state, rb = (st.robots || {})[id];
    if (!rb) return '<div class="empty">no such robot</div>';
    let html = '<table class="kv">';
    for (const k of ["holding", "incoming", "activity", "busy_until", "supports", "switch_lock", "ee"]) html += "<tr><td>" + k + '</td><td class="mono">' + esc(JSON.stringify(rb[k])) + "</td></tr>";
    const act = (pane.doc.actions || [])[t];
    if (act) html += '<tr><td>action at t</td><td class="mono">' + esc(act[id] || 0) + "</td></tr>";
    html += "</table>";
    if (!pane.doc.observations) return html + '<div class="hint">this trace has no observations (record it with --observations)</div>';
    if (t >= pane.doc.T) return html + '<div class="hint">no observation at the final state</div>';
    const ob = (pane.obs.at(t) || {})[id];
    if (!ob) return html + '<div class="hint">no observation for this robot</div>';
    html += "<h2>observation I<sub>t</sub></h2><table class=\"kv\">";
    for (const k of Object.keys(ob)) {
      if (k === "mask") continue;
      let v = ob[k];
      if (k === "neighbours" && Array.isArray(v)) v = v.map((n) => n.dir + ":" + n.robot + (n.holding ? "[" + itemText(n.holding) + "]" : "") + (n.busy ? " busy" : "") + (n.op ? " " + n.op : "") + (n.role ? "/" + n.role : "")).join("; ");
      html += "<tr><td>" + esc(k) + '</td><td class="mono">' + esc(typeof v === "string" ? v : JSON.stringify(v)) + "</td></tr>";
    }
    html += "</table>";
    if (Array.isArray(ob.mask)) {
      const taken = act ? (act[id] || 0) : 0;
      const groups = [["idle · deliver", 0, 2], ["pick slots", 2, 34], ["handoff N…NW", 34, 42], ["receive N…NW", 42, 50], ["support slots", 50, ob.mask.length]];
      html += '<div class="mask-legend">mask m<sub>t</sub> (O-MASK, O-ACTION-ENCODING): ' + ob.mask.filter(Boolean).length + " of " + ob.mask.length +
        " legal · green legal, outlined = the applied action · hover a slot</div>";
      for (const [name, lo, hi] of groups) {
        html += '<div class="mask-group"><span class="hint">' + name + " (" + lo + "–" + (hi - 1) + ')</span><div class="mask">';
        for (let a = lo; a < hi; a++) html += '<span class="' + (ob.mask[a] ? "on" : "") + (a === taken ? " taken" : "") + '" title="' + esc(slotLabel(a, ob)) + (ob.mask[a] ? " (legal)" : "") + '"></span>';
        html += "</div></div>";
      }
    }
    return html;
  }

  // ------------------------------------------------------------------ the viewer (timeline, counters)
  function entitiesOf(pointers, st) {
    // JSON Pointers of differences (O-GLOBAL-STATE paths) -> robots and items to highlight
    const robots = new Set(), items = new Set();
    for (const ptr of pointers || []) {
      const p = ptr.split("/").slice(1).map((x) => x.replace(/~1/g, "/").replace(/~0/g, "~"));
      const head = p[0] === "state" ? p.slice(1) : p;
      if (head[0] === "robots" && head[1]) robots.add(head[1]);
      else if (head[0] === "items" && head[1]) { items.add(head[1]); for (const s of st) { const h = (s.items || {})[head[1]]; if (h) robots.add(h); } }
      else if (head[0] === "activities" && head[1] !== undefined) for (const s of st) { const a = (s.activities || [])[+head[1]]; if (a) (a.members || []).forEach((m) => robots.add(m)); }
      else if (head[0] === "proposals" && head[1]) candidateMembers(head[1]).forEach((m) => robots.add(m));
      else if (head[0] === "observations" || head[0] === "masks") { if (head[1]) robots.add(head[1]); }
    }
    return { robots: robots, items: items };
  }

  function tickFromHash(hash) {
    const m = /(?:^#|&)t=(\d{1,9})(?:&|$)/.exec(hash || "");
    return m ? +m[1] : null;
  }

  const viewer = {
    t: 0, T: 0, selected: null, timer: null, panes: [],
    init() {
      const stage = document.getElementById("stage");
      if (DATA.mode === "diff") {
        // the observed side is what the implementation sent (absent when it sends no state)
        this.panes.push(new Pane(stage, DATA.expected, "expected · " + (DATA.labels && DATA.labels.expected || "reference"), "expected"));
        if (DATA.actual) this.panes.push(new Pane(stage, DATA.actual, "observed · " + (DATA.labels && DATA.labels.actual || "implementation"), "actual"));
        this.T = DATA.actual ? Math.min(DATA.expected.T, DATA.actual.T) : DATA.expected.T;
      } else {
        this.panes.push(new Pane(stage, DATA.replay, null, "replay"));
        this.T = DATA.replay.T;
      }
      const doc = this.panes[0].doc;
      document.getElementById("title").textContent = DATA.title || doc.title;
      document.title = DATA.title || doc.title;
      const L = doc.layout, src = doc.source || {};
      const named = (s) => s && s.implementation ? (s.implementation.name + " " + (s.implementation.version || "")).trim() : "?";
      const impl = DATA.mode === "diff"
        ? "expected " + named(src) + (DATA.actual ? " · observed " + named(DATA.actual.source) : " · observed: no state sent")
        : "implementation " + named(src);
      document.getElementById("subtitle").textContent = [L.scenario, L.grid.rows + "×" + L.grid.cols + " " + (L.grid.topology || ""),
        "profile " + (L.profile.id || "?") + (L.profile.variant ? "/" + L.profile.variant : ""), impl,
        src.controller && src.controller.name ? "controller " + src.controller.name : null, doc.footer ? null : "no footer: truncated trace"].filter(Boolean).join(" · ");
      const kmean = doc.footer && doc.footer.metrics && doc.footer.metrics.capacity_mean;
      this.kmean = (kmean !== undefined && kmean !== null) ? kmean : null;
      document.getElementById("kstar-box").hidden = !((doc.kstar && doc.kstar.length) || this.kmean !== null);
      const scrub = document.getElementById("scrub");
      scrub.max = String(this.T);
      document.getElementById("tick-of").textContent = "/ " + this.T;
      scrub.addEventListener("input", () => this.go(+scrub.value));
      document.getElementById("step-back").addEventListener("click", () => { this.pause(); this.go(this.t - 1); });
      document.getElementById("step-fwd").addEventListener("click", () => { this.pause(); this.go(this.t + 1); });
      document.getElementById("play").addEventListener("click", () => this.timer ? this.pause() : this.play());
      document.getElementById("speed").addEventListener("change", () => { if (this.timer) { this.pause(); this.play(); } });
      document.getElementById("show-reach").addEventListener("change", (e) => this.panes.forEach((p) => p.showReach(e.target.checked)));
      document.getElementById("show-ids").addEventListener("change", (e) => this.panes.forEach((p) => p.showIds(e.target.checked)));
      document.addEventListener("keydown", (e) => {
        if (e.target && e.target.tagName === "SELECT") return;
        if (e.key === "ArrowRight") { this.pause(); this.go(this.t + 1); e.preventDefault(); }
        else if (e.key === "ArrowLeft") { this.pause(); this.go(this.t - 1); e.preventDefault(); }
        else if (e.key === " ") { this.timer ? this.pause() : this.play(); e.preventDefault(); }
      });
      this.legend();
      // the page opens at the tick named in the URL (`page.html#t=120`) and keeps the URL at the shown tick
      window.addEventListener("hashchange", () => { const h = tickFromHash(location.hash); if (h !== null && h !== this.t) this.go(h); });
      const start = tickFromHash(location.hash);
      this.go(start !== null ? start : DATA.mode === "diff" ? Math.min(DATA.focus || 0, this.T) : 0);
    },
    play() {
      if (this.t >= this.T) this.go(0);
      const fps = +document.getElementById("speed").value || 5;
      document.getElementById("play").textContent = "Pause";
      this.timer = setInterval(() => { if (this.t >= this.T) this.pause(); else this.go(this.t + 1); }, 1000 / fps);
    },
    pause() {
      if (this.timer) clearInterval(this.timer);
      this.timer = null;
      document.getElementById("play").textContent = "Play";
    },
    select(id) { this.selected = this.selected === id ? null : id; this.go(this.t); },
    go(t) {
      t = Math.max(0, Math.min(this.T, Math.round(t)));
      this.t = t;
      if (tickFromHash(location.hash) !== t) {
        try { history.replaceState(null, "", "#t=" + t); } catch (e) { /* a sandboxed page keeps its URL */ }
      }
      let hl = null;
      if (DATA.mode === "diff") {
        const ptrs = (DATA.differences || {})[String(t)] || [];
        hl = entitiesOf(ptrs, this.panes.map((p) => p.states.at(t)));
        this.diffPanel(t, ptrs);
      }
      this.panes.forEach((p) => p.render(t, hl));
      const pane = this.panes[this.panes.length - 1], st = pane.state;
      document.getElementById("scrub").value = String(t);
      document.getElementById("tick").textContent = String(t);
      document.getElementById("delivered").textContent = String(st.delivered);
      document.getElementById("wip").textContent = String(st.wip);
      document.getElementById("released").textContent = String(st.released);
      document.getElementById("lost").textContent = String(st.lost_releases);
      document.getElementById("throughput").textContent = t > 0 ? fmt(st.delivered / t, 3) : "–";
      const n = Object.keys(st.robots || {}).length;
      document.getElementById("occupancy").textContent = n ? fmt(pane.busy / n, 2) : "–";
      const ks = pane.doc.kstar || [];
      // K*(s_t) where the reference reproduced s_t (capacity.py); otherwise the episode mean from the footer
      document.getElementById("kstar-label").textContent = t < ks.length ? "K*" : "K* mean";
      document.getElementById("kstar").textContent = t < ks.length ? String(ks[t]) : (this.kmean !== null ? fmt(this.kmean, 2) : "–");
      document.getElementById("coalitions").textContent = String((st.activities || []).filter((a) => a.kind === "operation" && (a.members || []).length >= 2).length);
      document.getElementById("activities").innerHTML = activitiesHtml(st);
      document.getElementById("proposals").innerHTML = proposalsHtml(st);
      document.getElementById("events").innerHTML = eventsHtml(pane.events, t);
      document.getElementById("sel-name").textContent = this.selected || "(click a robot)";
      document.getElementById("robot-panel").innerHTML = this.selected ? robotHtml(pane, this.selected, t) : '<div class="hint">click a robot to see its state' + (pane.doc.observations ? ", observation and mask" : "") + "</div>";
    },
    diffPanel(t, ptrs) {
      const box = document.getElementById("diff-panel"), f = DATA.failure || {};
      box.hidden = false;
      let html = "<h2>Divergence</h2><div><b>" + esc(DATA.case_id || "") + "</b> " + esc(f.message || "") + "</div>" +
        '<div class="hint">first divergence ' + esc(f.reply || ("at state index " + DATA.focus)) + " · " + esc(DATA.actual_source || "") + "</div>" +
        (f.known_divergence ? '<div class="hint">known divergence ' + esc(f.known_divergence.id) + " — " + esc(f.known_divergence.title) + "</div>" : "");
      html += '<div class="diff-list">' + (ptrs.length ? ptrs.slice(0, 40).map((p) => {
        const v = (DATA.values || {})[t + "|" + p];
        return '<div class="row mono">' + esc(p) + (v ? '<br><span class="exp">expected ' + esc(v[0]) + '</span><br><span class="act">observed ' + esc(v[1]) + "</span>" : "") + "</div>";
      }).join("") + (ptrs.length > 40 ? '<div class="hint">… ' + (ptrs.length - 40) + " more</div>" : "") : '<div class="empty">no difference at this tick</div>') + "</div>";
      box.innerHTML = html;
    },
    legend() {
      const sw = (style, text) => '<span><svg width="16" height="14"><rect x="1" y="1" width="14" height="12" rx="3" style="' + style + '"/></svg>' + text + "</span>";
      const parts = [
        sw("fill:#eef0f3;stroke:#b9c0cb", "idle robot"),
        sw("fill:#cfe3f7;stroke:#b9c0cb", "pick / handoff / delivery"),
        sw("fill:#e4572e33;stroke:#e4572e;stroke-width:2", "coalition member (one colour per operation; role; phase k/n = tick k of the phase's n)"),
        '<span><svg width="16" height="14"><polygon points="8,1 15,7 8,13 1,7" fill="#e4572e"/></svg>operation target</span>',
        sw("fill:#2f3b52", "material item product:token, below its holder (a line to the end effector holding it)"),
        '<span><svg width="22" height="14"><line x1="1" y1="7" x2="21" y2="7" stroke="#e09f1f" stroke-width="2.5" stroke-dasharray="5 3"/></svg>pending support k/|U|</span>',
        sw("fill:none;stroke:#d62828;stroke-width:2", "blocked attempt (cause shown)"),
        sw("fill:#fff4dc;stroke:#c9a227", "shelf (stock)"),
        sw("fill:#e6f4ea;stroke:#34a853", "output"),
        '<span><svg width="16" height="14"><circle cx="8" cy="7" r="6" fill="none" stroke="#3d7bc4" stroke-dasharray="3 2"/></svg>incoming handoff</span>',
      ];
      if (DATA.mode === "diff") parts.push(sw("fill:none;stroke:#d1008f;stroke-width:3", "differs between expected and observed"));
      parts.push('<span class="hint">an activity lasts approach + process + retreat ticks (G-DURATION): the arm moves to its target, ' +
        "works for the operation's duration, then retracts · K*: the most activities that could start together in this state " +
        "(M-CAPACITY) · occupancy: share of robots busy now (M-OCCUPANCY) · keys: ← → step, space play/pause · " +
        "<code>agspec explain ID</code> defines every spec ID</span>");
      document.getElementById("legend").innerHTML = parts.join("");
    },
  };

  window.agspecViewer = {
    go: (t) => viewer.go(t),
    tick: () => viewer.t,
    T: () => viewer.T,
    stateAt: (t, pane) => viewer.panes[pane || 0].states.at(t),
    observationsAt: (t) => viewer.panes[0].obs.at(t),
  };
  viewer.init();
})();
