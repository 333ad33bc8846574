/* agspec trace viewer: replays an agspec-replay/1 document (docs/viewer.md) in inline SVG.
 * No network, no dependencies. States are rebuilt from the nearest keyframe plus per-tick diffs
 * (applyDiff mirrors agspec/viewer/encode.py apply_diff). Spec IDs: O-GLOBAL-STATE (state fields),
 * G-BASE / RES-SHELF-POINT / G-OUTPUT-POINT (layout), G-DURATION (phases), O-SUPPORT-FRACTION,
 * F-TRACE-EVENTS (event vocabulary), O-ACTION-ENCODING (mask slots). */
(function () {
  "use strict";
  const DATA = JSON.parse(document.getElementById("replay-data").textContent);
  const { DIRS, esc, el, colourOf, rc, candidateMembers, fmt, Decoder, phaseOf, phaseText, phaseTitle, involvedRobots, describeEvent } = AgspecModel;

  // ------------------------------------------------------------------ one grid pane
  class Pane {
    constructor(container, doc, label, id) {
      this.doc = doc;
      this.states = new Decoder(doc.states);
      this.obs = new Decoder(doc.observations);
      const L = doc.layout;
      this.rows = L.grid.rows; this.cols = L.grid.cols;
      this.s = Number(L.profile.spacing) || 1; this.reach = Number(L.profile.reach) || 1.5;
      this.S = AgspecLayout.PITCH / this.s; // pixels per task-space unit: one spacing is PITCH px whatever s
      this.x0 = 1.35 * this.s; this.y0 = 0.75 * this.s;
      const wrap = document.createElement("div");
      wrap.className = "pane"; if (id) wrap.id = id;
      if (label) { const h = document.createElement("h3"); h.textContent = label; wrap.appendChild(h); }
      container.appendChild(wrap);
      const W = this.cols * this.s + this.x0 + 0.55 * this.s, H = (this.rows - 1) * this.s + 2 * this.y0;
      this.W = W * this.S; this.H = H * this.S;
      this.svg = el("svg", { viewBox: "0 0 " + this.W.toFixed(1) + " " + this.H.toFixed(1), role: "img" }, wrap);
      this.layers = {};
      for (const name of ["static", "reach", "props", "acts", "robots", "leaders", "items", "labels"]) this.layers[name] = el("g", { class: "layer-" + name }, this.svg);
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
        this.shelfEls.push(el("text", { class: "stock", x: this.X(-1.2 * s), y: this.Y(r * s + 0.12 * s), "font-weight": 600 }, sg));
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
      // robots: the cell and, inside it, fixed slots for the id (top left), the incoming-handoff mark
      // (top right), the role (centre) and the phase (bottom); the rings lie outside the cell, each in
      // its own band (layout.js), so no text of the cell ever meets a ring
      const C = AgspecLayout.CELL, RING = AgspecLayout.RING;
      const ring = (cls, cx, cy, [off, w], rx, g) => el("rect", { class: cls, x: cx - C - off, y: cy - C - off, width: 2 * (C + off), height: 2 * (C + off), rx: rx, "stroke-width": w }, g);
      for (let i = 0; i < this.rows; i++) for (let j = 0; j < this.cols; j++) {
        const id = i + "," + j, cx = +this.X(j * s), cy = +this.Y(i * s);
        const rg = el("g", { class: "robot", "data-robot": id, "data-coalition": "", "data-role": "", tabindex: 0 }, this.layers.robots);
        const cell = el("rect", { class: "cell", x: cx - C, y: cy - C, width: 2 * C, height: 2 * C, rx: 7 }, rg);
        ring("blocked-ring", cx, cy, RING.blocked, 9, rg);
        const support = ring("support-ring", cx, cy, RING.support, 11, rg);
        ring("diff-ring", cx, cy, RING.diff, 13, rg);
        const inc = el("circle", { class: "incoming", cx: cx + C - 9, cy: cy - C + 9, r: 5 }, rg);
        el("title", {}, inc).textContent = "incoming handoff";
        const rid = el("text", { class: "rid", x: cx - C + 4, y: cy - C + 12 }, rg);
        rid.textContent = id;
        AgspecLayout.fit(rid, 2 * C - 22);
        const role = el("text", { class: "role", x: cx, y: cy + 3.5, "text-anchor": "middle" }, rg);
        const phase = el("text", { class: "phase", x: cx, y: cy + C - 6, "text-anchor": "middle" }, rg);
        const phaseTitleEl = el("title", {}, phase);
        const title = el("title", {}, rg);
        rg.addEventListener("click", () => viewer.select(id));
        this.robotEls[id] = { g: rg, cell: cell, role: role, phase: phase, phaseTitle: phaseTitleEl, incoming: inc, support: support, title: title };
      }
      this.rowYs = Array.from({ length: this.rows }, (_, i) => +this.Y(i * s));
    }
    render(t, highlight) {
      const st = this.states.at(Math.min(t, this.doc.T));
      const events = this.doc.events[Math.min(t, this.doc.T)] || [];
      this.state = st; this.t = t; this.events = events;
      const s = this.s, S = this.S;
      // shelves stock
      (st.shelves || []).forEach((stock, r) => {
        if (!this.shelfEls[r]) return;
        this.shelfEls[r].textContent = Object.keys(stock || {}).map((k) => k + "×" + stock[k]).join(" ");
        AgspecLayout.fit(this.shelfEls[r], (0.62 * s - 0.1 * s) * S);
      });
      // activities: colours, roles, phases
      const actOf = {};
      (st.activities || []).forEach((a) => (a.members || []).forEach((m) => { actOf[m] = a; }));
      const blocked = {};
      for (const ev of events) if (ev.type === "blocked" || ev.type === "admission_failed") for (const r of involvedRobots(ev)) blocked[r] = ev;
      const hl = highlight || { robots: new Set(), items: new Set() };
      // a pending support of a single-member candidate rings its robot (the others draw a polyline)
      const supported = new Set();
      for (const cand in st.proposals || {}) { const m = candidateMembers(cand); if (m.length === 1) supported.add(m[0]); }
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
        R.support.style.display = supported.has(id) ? "" : "none";
        R.title.textContent = id + (rb.holding ? " holding " + rb.holding : "") + (a ? " · " + a.id : "") + (rb.supports ? " · supports " + rb.supports : "");
      }
      this.busy = busy;
      const C = AgspecLayout.CELL;
      for (const id in this.robotEls) { AgspecLayout.fit(this.robotEls[id].role, 2 * C - 6); AgspecLayout.fit(this.robotEls[id].phase, 2 * C - 6); }
      if (viewer.selected && this.robotEls[viewer.selected]) {
        const [bx, by] = this.base(viewer.selected);
        this.selReach.setAttribute("cx", this.X(bx)); this.selReach.setAttribute("cy", this.Y(by));
        this.selReach.style.display = "";
      } else this.selReach.style.display = "none";
      this.labels = [];
      this.renderActs(st, blocked, events);
      this.renderItems(st, hl);
      this.placeLabels();
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
              const tx = el("text", { class: "proposal-label op-label", style: "fill:" + c }, lab);
              tx.textContent = (a.operation || "op") + " · " + phaseOf(a, st.t).phase;
              this.labels.push({ node: tx, order: 2, px: x, py: y + 14, ax: x, ay: y, colour: c });
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
        const tx = el("text", { class: "proposal-label" }, lab);
        tx.textContent = "support " + sup + "/" + members.length;
        this.labels.push({ node: tx, order: 3, px: +this.X(cx), py: +this.Y(cy), ax: +this.X(cx), ay: +this.Y(cy) });
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
        const tx = el("text", { class: "blocked-label" }, lab);
        tx.textContent = ev.type === "blocked" ? "blocked: " + ev.cause + " (" + ev.kind + ")" : "admission failed: " + ev.reason;
        this.labels.push({ node: tx, order: 1, px: +this.X(bx), py: +this.Y(by + 0.5 * s), ax: +this.X(bx), ay: +this.Y(by) + AgspecLayout.CELL, colour: "var(--blocked)" });
      }
    }
    renderItems(st, hl) {
      // drawn from the robots' `holding` (so a duplicated item shows twice); `items` (item -> holder)
      // should agree — an item whose map entry names another holder is drawn with a warning outline
      const items = st.items || {}, seen = new Set();
      const held = [];
      for (const id in st.robots || {}) { const h = st.robots[id].holding; if (h !== null && h !== undefined) held.push([String(h), id]); }
      for (const item in items) if (!held.some((x) => x[0] === item && x[1] === items[item]) && (st.robots || {})[items[item]]) held.push([item, items[item]]);
      const copies = {};
      for (const [item, holder] of held) {
        // keyed by item (a second copy gets "#2"), so an item changing holder moves (CSS transition)
        copies[item] = (copies[item] || 0) + 1;
        const rb = st.robots[holder], key = copies[item] > 1 ? item + "#" + copies[item] : item;
        seen.add(key);
        const p = Array.isArray(rb.ee) ? rb.ee : this.base(holder);
        let node = this.itemEls[key];
        if (!node) {
          // the whole id, in a tag 4 px wider than its text on each side
          node = el("g", { class: "item", "data-item": item }, this.layers.items);
          el("line", { class: "leader", x1: 0, y1: 0, x2: 0, y2: 0 }, node);
          const rect = el("rect", { height: 15, rx: 3, y: -7.5 }, node);
          const text = el("text", { x: 0, y: 3, "text-anchor": "middle" }, node);
          text.textContent = item;
          const w = Math.max(24, AgspecLayout.measure(text).w + 8);
          rect.setAttribute("x", -w / 2); rect.setAttribute("width", w);
          el("title", {}, node);
          node.labelWidth = w;
          this.itemEls[key] = node;
        }
        const consistent = items[item] === holder && rb.holding === item;
        node.setAttribute("data-holder", holder);
        node.lastChild.textContent = "item " + item + " held by " + holder + (consistent ? "" : " (state.items says " + (items[item] || "nothing") + ")");
        node.setAttribute("class", "item" + (hl.items.has(item) || hl.robots.has(holder) ? " diff" : "") + (consistent ? "" : " inconsistent"));
        // wanted in the channel below the holder's cell; a leader line points at the end effector
        // that holds it (G-END-EFFECTOR)
        const [bx, by] = this.base(holder);
        this.labels.push({ item: node, order: 0, w: node.labelWidth, h: 15, px: +this.X(bx), py: +this.Y(by + 0.5 * this.s),
                           ax: +this.X(p[0]), ay: +this.Y(p[1]), key: [by, bx, copies[item]] });
      }
      for (const key in this.itemEls) if (!seen.has(key)) { this.itemEls[key].remove(); delete this.itemEls[key]; }
    }
    placeLabels() {
      // item tags first (by holder), then blocked causes, operation labels, pending supports, each
      // group in a stable order so that frames do not jitter (layout.js)
      const placer = new AgspecLayout.Placer(this.rowYs, this.W, this.H);
      const leaders = this.layers.leaders;
      leaders.textContent = "";
      const ordered = this.labels.map((q, i) => [q, i]).sort((a, b) => a[0].order - b[0].order ||
        (a[0].key && b[0].key ? a[0].key[0] - b[0].key[0] || a[0].key[1] - b[0].key[1] || a[0].key[2] - b[0].key[2] : a[1] - b[1]));
      for (const [q] of ordered) {
        if (q.item) {
          const at = placer.place(q.w, q.h, q.px, q.py);
          q.item.style.transform = "translate(" + at.x + "px," + at.y + "px)";
          const leader = q.item.firstChild;
          leader.setAttribute("x2", (q.ax - at.x).toFixed(1)); leader.setAttribute("y2", (q.ay - at.y).toFixed(1));
          continue;
        }
        const b = AgspecLayout.measure(q.node);
        const at = placer.place(b.w, b.h, q.px, q.py);
        q.node.setAttribute("x", (at.x - b.x - b.w / 2).toFixed(1));
        q.node.setAttribute("y", (at.y - b.y - b.h / 2).toFixed(1));
        if (Math.hypot(at.x - q.px, at.y - q.py) > 6) // moved away from where it belongs: a leader back to it
          el("line", { class: "label-leader", x1: at.x.toFixed(1), y1: at.y.toFixed(1), x2: q.ax.toFixed(1), y2: q.ay.toFixed(1), style: q.colour ? "stroke:" + q.colour : "" }, leaders);
      }
      if (placer.H > this.H) { // no room left on the grid: the picture grows below it (never shrinks)
        this.H = placer.H;
        this.svg.setAttribute("viewBox", "0 0 " + this.W.toFixed(1) + " " + this.H.toFixed(1));
      }
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

  function counterValues(pane, t) {
    const st = pane.state, n = Object.keys(st.robots || {}).length;
    return {
      delivered: String(st.delivered), wip: String(st.wip), released: String(st.released), lost: String(st.lost_releases),
      throughput: t > 0 ? fmt(st.delivered / t, 3) : "–", occupancy: n ? fmt(pane.busy / n, 2) : "–",
      coalitions: String((st.activities || []).filter((a) => a.kind === "operation" && (a.members || []).length >= 2).length),
    };
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
      if (DATA.mode === "diff") {
        // say whose numbers the header shows: the observed side, the expected one under it
        const cap = document.getElementById("counters-caption");
        cap.hidden = false;
        cap.textContent = DATA.actual ? "counters: observed (implementation); exp = expected (reference)"
          : "counters: expected (reference); the implementation sent no state";
        for (const id of ["delivered", "wip", "released", "lost", "throughput", "occupancy", "coalitions"]) {
          const exp = document.createElement("span");
          exp.className = "exp"; exp.id = id + "-exp"; exp.hidden = true;
          document.getElementById(id).parentNode.appendChild(exp);
        }
      }
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
      // the counters show the last pane (the observed side of a --diff page); a --diff page with both
      // sides shows the expected value under each, marked where the two differ
      const shown = counterValues(pane, t);
      const other = this.panes.length > 1 ? counterValues(this.panes[0], t) : null;
      for (const id in shown) {
        document.getElementById(id).textContent = shown[id];
        const exp = document.getElementById(id + "-exp");
        if (!exp) continue;
        exp.hidden = !other;
        exp.textContent = other ? "exp " + other[id] : "";
        exp.parentNode.classList.toggle("differs", !!other && other[id] !== shown[id]);
      }
      const ks = pane.doc.kstar || [];
      // K*(s_t) where the reference reproduced s_t (capacity.py); otherwise the episode mean from the footer
      document.getElementById("kstar-label").textContent = t < ks.length ? "K*" : "K* mean";
      document.getElementById("kstar").textContent = t < ks.length ? String(ks[t]) : (this.kmean !== null ? fmt(this.kmean, 2) : "–");
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
