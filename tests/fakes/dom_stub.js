// Runs the viewer's scripts (agspec/viewer/assets/model.js, layout.js, viewer.js, in the page's order) on a replay document under a stub DOM in which every element
// accepts any property and method: enough to catch a script error of init() and go() without a
// browser (the headless-browser tests of tests/test_render.py check what is drawn).
//   node tests/fakes/dom_stub.js DOCUMENT.json SCRIPT.js...   -> prints one JSON line {T, subtitle, panel}
const fs = require("fs");
function fake() {
  const store = { style: {}, dataset: {}, classList: { add() {}, remove() {}, toggle() {} } };
  return new Proxy(function () {}, {
    get(t, k) {
      if (k in store) return store[k];
      if (k === "textContent" || k === "innerHTML" || k === "value") return "";
      if (k === Symbol.toPrimitive) return () => "";
      if (k === "getBBox") return () => ({ x: 0, y: 0, width: 10, height: 10 });
      if (k === "querySelectorAll") return () => [];
      return fake();
    },
    set(t, k, v) { store[k] = v; return true; },
    apply() { return fake(); },
  });
}
const data = fs.readFileSync(process.argv[2], "utf8");
const els = {};
global.document = {
  getElementById: (id) => id === "replay-data" ? { textContent: data } : (els[id] = els[id] || fake()),
  createElementNS: () => fake(), createElement: () => fake(), addEventListener() {}, title: "",
};
global.window = { addEventListener() {} };
global.location = { hash: "" };
global.history = { replaceState() {} };
global.setInterval = () => 1;
global.clearInterval = () => {};
// one eval of the scripts joined, as the page's classic scripts share one global scope
eval(process.argv.slice(3).map((f) => fs.readFileSync(f, "utf8")).join("\n;\n"));
const v = window.agspecViewer;
for (let t = 0; t <= v.T(); t++) v.go(t);
const text = (id) => (els[id] && typeof els[id].textContent === "string") ? els[id].textContent : "";
const html = (id) => (els[id] && typeof els[id].innerHTML === "string") ? els[id].innerHTML : "";
console.log(JSON.stringify({ T: v.T(), subtitle: text("subtitle"), panel: html("diff-panel") }));
