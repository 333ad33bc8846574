/* agspec trace viewer: the scene's geometry and its label placement (docs/viewer.md, "Layout").
 *
 * A robot's cell (G-BASE) holds its own texts (id, role, phase) and its incoming-handoff mark, each in
 * a fixed slot inside the cell; the rings that mark a robot (blocked, pending single support, differs)
 * lie just outside it, each in its own band. Everything else that is written on the grid — item tags
 * (material, O-GLOBAL-STATE items), blocked causes (R-BLOCKING), pending supports
 * (O-SUPPORT-FRACTION), operation labels — is placed by the Placer into the free channels between
 * the rows of cells: never on a cell, a ring, a shelf, an output or another label. A label that finds
 * no room near its anchor moves along its channel, then to the next channel, and as a last resort
 * into a channel added below the grid (the picture grows, never shrinks, so frames do not jump). */
const AgspecLayout = (function () {
  "use strict";
  const CELL = 30;          // half side of a robot's cell, px
  const PITCH = 104;        // px between neighbouring robots (one spacing s)
  const RING = { blocked: [2, 3], support: [5.25, 2.5], diff: [8.75, 4] }; // offset outside the cell, stroke
  const KEEP = CELL + 11;   // half height of a row of cells with its outermost ring band
  const PAD = 2;            // px kept free around every placed label
  const STEP = 4;           // px a label moves along its channel per try

  const sizes = new Map();  // "class|text" -> the text's box relative to its (x, y) anchor
  function measure(node) {
    const key = node.getAttribute("class") + "|" + node.textContent;
    let b = sizes.get(key);
    if (!b) {
      const x = +node.getAttribute("x") || 0, y = +node.getAttribute("y") || 0, bb = node.getBBox();
      b = { x: bb.x - x, y: bb.y - y, w: bb.width, h: bb.height };
      if (b.w > 0) sizes.set(key, b);
    }
    return b;
  }
  // a text wider than its slot is condensed to the slot (SVG textLength), never spilled over its cell
  function fit(node, width) {
    node.removeAttribute("textLength");
    node.removeAttribute("lengthAdjust");
    if (!node.textContent) return;
    const w = measure(node).w;
    if (w > width) { node.setAttribute("textLength", width.toFixed(1)); node.setAttribute("lengthAdjust", "spacingAndGlyphs"); }
  }

  const hits = (a, b) => a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1;

  class Placer {
    /* rows: the y (px) of each row of cells; W, H: the picture's size; the free channels are the
     * bands between [y - KEEP, y + KEEP] of consecutive rows, above the first and below the last */
    constructor(rows, W, H) {
      this.W = W; this.H = H; this.boxes = [];
      this.channels = [];
      let top = 0;
      for (const y of rows) { if (y - KEEP > top) this.channels.push([top, y - KEEP]); top = y + KEEP; }
      if (H > top) this.channels.push([top, H]);
    }
    free(b) { return b.x0 >= 0 && b.x1 <= this.W && !this.boxes.some((o) => hits(o, b)); }
    slots(h) {
      const out = [];
      for (const [a, b] of this.channels) {
        const n = Math.floor((b - a) / (h + 2 * PAD));
        const off = (b - a - n * (h + 2 * PAD)) / 2;
        for (let k = 0; k < n; k++) out.push(a + off + k * (h + 2 * PAD) + PAD + h / 2);
      }
      return out;
    }
    /* the free centre nearest (px, py) for a w x h label (below before above on a tie), or a new
     * channel below everything; returns {x, y, grown} */
    place(w, h, px, py) {
      // candidates in order of |dy| + |dx|: each slot keeps its next offset along the channel and the
      // slot whose next candidate is cheapest is tried first (a merge, not a sort of every position)
      const rows = this.slots(h).map((y) => ({ y: y, dy: Math.abs(y - py) + (y < py ? 0.5 : 0), d: 0, side: 1 }));
      const tryAt = (x, y) => {
        const b = { x0: x - w / 2 - PAD, x1: x + w / 2 + PAD, y0: y - h / 2 - PAD, y1: y + h / 2 + PAD };
        if (!this.free(b)) return false;
        this.boxes.push(b);
        return true;
      };
      for (;;) {
        let best = null;
        for (const r of rows) if (r.d <= this.W && (!best || r.dy + r.d < best.dy + best.d)) best = r;
        if (!best) break;
        const x = px + best.side * best.d;
        if (tryAt(x, best.y)) return { x: x, y: best.y, grown: false };
        if (best.d === 0 || best.side < 0) { best.d += STEP; best.side = 1; } else best.side = -1;
      }
      const y0 = this.H;
      this.H += h + 4 * PAD;
      this.channels.push([y0, this.H]);
      const at = this.place(w, h, Math.min(Math.max(px, w / 2 + PAD), this.W - w / 2 - PAD), this.H);
      at.grown = true;
      return at;
    }
  }

  return { CELL: CELL, PITCH: PITCH, RING: RING, KEEP: KEEP, measure: measure, fit: fit, Placer: Placer };
})();
