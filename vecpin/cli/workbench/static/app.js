// The vecpin workbench page: one section per stage of the day. Every value here is a choice
// the server keeps in the folder's session.json; every result is a file a vecpin command wrote.
"use strict";

// Each stage's form is built from its command's own options (/api/options: argparse's type,
// choices, default and help); `main` names the ones shown first, the rest are under "more options".
const UI = [
  {id: "machine", title: "Machine", what: "The machine (a bundled name or a URDF path), its axes and frames, the " +
    "volumetric error you accept after compensation (mm) and the tracker's place, set once for the day.", run: "Show axes and frames",
   fields: [{name: "machine", kind: "text", help: "a bundled machine name or a URDF path"},
            {name: "tolerance_mm", kind: "number", help: "the volumetric error you accept after compensation, mm"},
            {name: "tracker", kind: "text", help: "the tracker's place, X,Y,Z mm in the machine's base frame: set " +
             "once for the day, every stage whose command takes it gets it (a stage's own field wins)"}]},
  {id: "plan", title: "Plan", what: "Points, zones, tracker place; the line of sight is tested unless switched off.",
   run: "Plan", images: ["plan/plan.png"], main: ["points", "order", "tracker", "exclude", "repeat", "candidates",
                                                   "validation-count", "dialect", "no-sight"]},
  {id: "programs", title: "Programs", what: "The measurement and validation programs the plan wrote (dialects: the " +
   "plan's field above).", view: "programs"},
  {id: "import", title: "Import the tracker export", run: "Import", what: "The tracker software's export joined to " +
   "the plan by point name: the column mapping and any unmatched rows below.",
   main: ["export", "columns", "units", "ignore-unmatched"]},
  {id: "assess", title: "Assess", run: "Assess", what: "Is compensation worth it? Repeatability, drift, the " +
   "instrument's floor and the uncompensated error.", main: []},
  {id: "fit", title: "Fit", run: "Fit", what: "The model the data choose (or the one you fix), with its held-out " +
   "figures.", scene: true, main: ["model", "basis", "order"]},
  {id: "evaluate", title: "Evaluate", run: "Evaluate", what: "The model's residuals on the campaign.", main: []},
  {id: "diagnose", title: "Diagnose", run: "Diagnose", what: "What the model does not explain: the three sentences " +
   "first, then the ambiguity and what to measure next.", main: ["effects"]},
  {id: "profile", title: "Controller profile", what: "What the controller's files need from the machine: fill in " +
   "every null the template marks as needed.", view: "profile"},
  {id: "tables", title: "Tables and files", run: "Write the tables", what: "What the machine gets, in the " +
   "controller's format, and the error it keeps in the part's frame.",
   main: ["controller", "profile", "method", "table-points", "max-tables"]},
  {id: "import_before", title: "Import the validation run without the tables", run: "Import",
   what: "The tracker export of the plan's validation program run without the tables, joined to the plan's " +
   "validation run (plan/validation.csv).", main: ["export", "columns"]},
  {id: "import_after", title: "Import the validation run with the tables", run: "Import",
   what: "The same program run again with the tables loaded, its tracker export.", main: ["export", "columns"]},
  {id: "verify", title: "Verify", run: "Verify", images: ["verify/verify.png"], what: "The validation run without " +
   "and with the tables, in the part's frame.", main: ["before", "after"]},
  {id: "report", title: "Compensation record", what: "What was measured, fitted, written and verified, with " +
   "versions (ISO/TR 16907 clauses 11 and 12).", view: "report"},
];
const STAGES = ["plan", "import", "assess", "fit", "evaluate", "diagnose", "tables", "import_before", "import_after",
                "verify"];
let state = null, polling = null, logs = {}, drawn = {}, extra = {};

const $ = (id) => document.getElementById(id);
const el = (tag, attrs = {}, ...kids) => {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) { if (k === "text") e.textContent = v; else e.setAttribute(k, v); }
  for (const k of kids) e.append(k);
  return e;
};

async function api(path, body) {
  const headers = {"Content-Type": "application/json", "X-Vecpin-Workbench": "1"};   // the server's check
  const r = await fetch(path, body === undefined ? {} : {method: "POST", headers, body: JSON.stringify(body)});
  const data = await r.json();
  if (!r.ok) throw new Error(data.error || r.statusText);
  return data;
}

function field(stage, f) {
  // one labelled input for one option: its kind says how it is typed, its help is its title
  const id = `${stage}-${f.name}`;
  let input;
  const dflt = f.default === null || f.default === undefined || f.default === false ? "" : `default ${f.default}`;
  if (f.kind === "choice") {
    input = el("select", {id});
    input.append(el("option", {value: "", text: `(${dflt || "default"})`}));
    for (const o of f.choices) input.append(el("option", {value: o, text: o}));
  } else if (f.kind === "switch") input = el("input", {id, type: "checkbox"});
  else {
    const hint = {list: "; between several", several: f.count ? `${f.count} values, spaces between` :
      "spaces between"}[f.kind] || "";
    input = el("input", {id, type: "text", size: 50, placeholder: [f.metavar, dflt, hint].filter(Boolean).join(", ")});
  }
  input.dataset.kind = f.kind;
  const label = el("label", {for: id, title: f.help || ""}, f.name, el("small", {text: f.help || ""}));
  return [label, input];
}

function buildForms(options) {
  // the stages' forms from their commands' options: `main` first, the others folded
  for (const s of UI) {
    const opts = options[s.id];
    if (!opts) continue;
    s.fields = opts;
    const main = opts.filter((o) => s.main.includes(o.name));
    const rest = opts.filter((o) => !s.main.includes(o.name));
    const grid = el("div", {class: "fields"}, ...main.flatMap((f) => field(s.id, f)));
    const more = el("details", {class: "more"}, el("summary", {text: `more options (${rest.length})`}),
                    el("div", {class: "fields"}, ...rest.flatMap((f) => field(s.id, f))));
    $(`stage-${s.id}`).querySelector(".what").after(grid, ...(rest.length ? [more] : []));
  }
}

function build() {
  const main = $("stages"); main.textContent = "";
  UI.forEach((s, k) => {
    $("nav").append(el("a", {href: "#stage-" + s.id, id: "nav-" + s.id}, el("span", {class: "dot", id: "dot-" + s.id}),
                       `${k + 1} ${s.title}`));
    const sec = el("section", {id: "stage-" + s.id}, el("h2", {text: `${k + 1}. ${s.title}`}),
                   el("p", {class: "what", text: s.what}));
    if (s.fields) sec.append(el("div", {class: "fields"}, ...s.fields.flatMap((f) => field(s.id, f))));
    const buttons = el("div", {class: "buttons"});
    if (s.run) buttons.append(button(`run-${s.id}`, s.run, () => runStage(s.id)));
    if (s.scene) buttons.append(button("run-scene", "Draw the scene", () => runStage("scene")));
    if (s.view === "profile") {
      buttons.append(el("select", {id: "profile-controller"}));
      buttons.append(button("run-profile", "Make the template", () => runStage("profile")));
      buttons.append(button("save-profile", "Save the profile", saveProfile), el("span", {id: "profile-saved"}));
    }
    if (s.view === "report") buttons.append(button("run-report", "Write the record", writeRecord));
    sec.append(buttons, el("div", {class: "command", id: `command-${s.id}`}), el("div", {id: `error-${s.id}`}),
               el("div", {id: `figure-${s.id}`}), el("div", {id: `output-${s.id}`}),
               el("div", {id: `result-${s.id}`}));
    if (s.scene) sec.append(el("div", {id: "scene"}));
    main.append(sec);
  });
  $("cancel").onclick = () => api("/api/cancel", {});
}

function button(id, text, fn) { const b = el("button", {id, text}); b.onclick = fn; return b; }

const NUM = /^[-+]?\d*\.?\d+(e[-+]?\d+)?$/i;
const typedWord = (t) => (NUM.test(t) ? Number(t) : t);

function readFields(s) {
  // the form as session fields: numbers as numbers (a bad one kept as typed: the command says why)
  const out = {};
  for (const f of s.fields || []) {
    const input = $(`${s.id}-${f.name}`);
    if (f.kind === "switch") { if (input.checked) out[f.name] = true; continue; }
    const v = input.value.trim();
    if (v === "") continue;
    if (f.kind === "int" || f.kind === "number") out[f.name] = typedWord(v);
    else if (f.kind === "list") out[f.name] = v.split(";").map((t) => t.trim()).filter(Boolean);
    else if (f.kind === "several") out[f.name] = v.split(/\s+/).map(typedWord);
    else out[f.name] = v;
  }
  return Object.assign({}, extra[s.id] || {}, out);
}

function fillFields(s, values) {
  const known = new Set((s.fields || []).map((f) => f.name));
  for (const f of s.fields || []) {
    const input = $(`${s.id}-${f.name}`), v = values[f.name];
    if (f.kind === "switch") input.checked = !!v;
    else if (v === undefined || v === null) input.value = "";
    else if (Array.isArray(v)) input.value = v.join(f.kind === "list" ? "; " : " ");
    else input.value = String(v);
  }
  foldedSummary(s, values);
  // a field the form does not know (a hand-written session) is kept: the command judges it
  extra[s.id] = Object.fromEntries(Object.entries(values).filter(([k]) => !known.has(k)));
}

function foldedSummary(s, values) {
  // the folded options' line says which of them are set
  const more = $(`stage-${s.id}`).querySelector("details.more summary");
  if (!more) return;
  const folded = (s.fields || []).filter((f) => !(s.main || []).includes(f.name));
  const set = folded.filter((f) => values[f.name] !== undefined && values[f.name] !== false).map((f) => f.name);
  more.textContent = `more options (${folded.length}${set.length ? `; set: ${set.join(", ")}` : ""})`;
}

async function saveStage(id) {
  const s = UI.find((u) => u.id === id);
  $(`error-${id}`).textContent = "";
  const fields = readFields(s);
  try {
    const r = await api(`/api/stage/${id}`, {fields});
    $(`command-${id}`).textContent = r.command || "";
    foldedSummary(s, fields);
    return true;
  } catch (e) { showError(id, e.message); return false; }
}

function showError(id, text) { $(`error-${id}`).replaceChildren(el("div", {class: "error", text})); }

async function runStage(id) {
  document.body.dataset.action = "busy";   // "done" once the stage's command ended or its choices were refused
  const owner = id === "scene" ? "fit" : id;
  if (id === "profile") {
    const fields = Object.assign({}, (state.session.stages || {}).tables || {},
                                 {controller: $("profile-controller").value});
    await api("/api/stage/tables", {fields}).catch(() => null);
  }
  const m = readFields(UI[0]), ses = state.session;   // the machine typed but not yet kept: kept first
  const kept = Object.assign({machine: ses.machine, tolerance_mm: ses.tolerance_mm}, ses.machine_options || {});
  const changed = [...new Set([...Object.keys(m), ...Object.keys(kept)])].some((k) =>
    JSON.stringify(m[k] ?? null) !== JSON.stringify(kept[k] ?? null));
  if (id !== "machine" && changed &&
      !(await saveStage("machine"))) { document.body.dataset.action = "done"; return; }
  if (!["scene", "profile"].includes(id) && !(await saveStage(id))) { document.body.dataset.action = "done"; return; }
  $(`error-${owner}`).textContent = "";
  try { await api(`/api/run/${id}`, {}); } catch (e) {
    showError(owner, e.message); document.body.dataset.action = "done"; return;
  }
  poll();
}

function poll() {
  // the job's state every 0.3 s while it is young (most stages end within seconds), then every second
  clearTimeout(polling);
  const young = !state || !state.job || state.job.elapsed_s < 3;
  polling = setTimeout(async () => {
    await refresh();
    if (state.job && state.job.running) poll(); else document.body.dataset.action = "done";
  }, young ? 300 : 1000);
}

async function refresh() {
  state = await api("/api/state");
  const job = state.job;
  $("folder").textContent = state.folder;
  if (state.load_error) showError("machine", state.load_error);
  if (job) {
    const owner = job.stage === "scene" ? "fit" : job.stage;
    logs[owner] = job;
    $("job-text").textContent = job.running ? `${job.stage}: running ${job.elapsed_s} s: ` +
      (job.lines[job.lines.length - 1] || "") : `${job.stage}: ${job.cancelled ? "cancelled" :
      job.code === 0 ? "done" : "failed"} (${job.elapsed_s} s)`;
    $("cancel").hidden = !job.running;
    document.body.dataset.job = job.running ? "running" : "idle";
  }
  showResults();
}

// the other numbers a stage's file holds beside its figure, as the figure table's rows
const MORE = {mean_mm: "mean", shape_mean_mm: "shape (best rigid motion removed as well): mean",
  heldout_mean_mm: "held-out mean", before_max_mm: "without the tables: max",
  before_mean_mm: "without the tables: mean", reduction_of_mean_pct: "reduction of the mean, %",
  mean_error_mm: "uncompensated error: mean", repeatability_mm: "repeatability", commands: "commands",
  rows: "rows", model: "model", bases: "bases", effects: "effects", verdict: "verdict", row: "the printout's row",
  frame: "judged in", points: "on"};

function figureBox(f, tol) {
  // the figure that matters against the tolerance, with the instrument's noise beside it
  const mm = (v) => (v === null || v === undefined ? "-" : `${Number(v).toFixed(4)} mm`);
  const verdict = f.passes === true ? "pass" : f.passes === false ? "fail" : "";
  const box = el("div", {class: "figure " + verdict});
  if (f.headline) box.append(el("ul", {}, ...f.headline.map((t) => el("li", {text: t}))));
  const row = (...cells) => el("tr", {}, ...cells.map((c) => el("td", {text: c})));
  const table = el("table", {class: "figures"}, el("tr", {}, ...["figure", "value", "tolerance", "instrument noise",
    "result"].map((h) => el("th", {text: h}))));
  if (f.value_mm !== null && f.value_mm !== undefined) {
    const badge = el("td", {}, el("span", {class: "badge " + verdict, text: f.passes === true ? "PASS" :
      f.passes === false ? "FAIL" : "not judged"}));
    table.append(el("tr", {}, el("td", {text: f.what}), el("td", {text: mm(f.value_mm)}),
                    el("td", {text: f.judged ? (tol ? mm(tol) : "not stated") : "-"}),
                    el("td", {text: mm(f.noise_mm)}), badge));
  }
  for (const [k, label] of Object.entries(MORE)) {
    const v = f[k];
    if (v === null || v === undefined) continue;
    const text = Array.isArray(v) ? v.join(", ") || "none" : k.endsWith("_mm") ? mm(v) : typeof v === "number" ?
      String(Math.round(v * 100) / 100) : String(v);
    table.append(row(label, text, "", "", ""));
  }
  box.append(table);
  return box;
}

function importTable(lines) {
  // the import's column mapping and its unmatched rows, as the command printed them
  const out = [];
  const cols = lines.find((l) => l.trim().startsWith("columns: "));
  if (cols) {
    const pairs = [...cols.matchAll(/(\w+) <- '([^']*)'/g)];
    out.push(el("table", {class: "figures", id: "columns-table"},
                el("tr", {}, el("th", {text: "campaign field"}), el("th", {text: "export column"})),
                ...pairs.map((m) => el("tr", {}, el("td", {text: m[1]}), el("td", {text: m[2]})))));
  }
  const rows = [];
  for (const l of lines) {
    const m = /^\s*(\d+) (planned points not in the export|export rows skipped \(not in the plan\)): (.*)$/.exec(l);
    if (m) rows.push(el("tr", {}, el("td", {text: m[2]}), el("td", {text: m[1]}), el("td", {text: m[3]})));
  }
  out.push(rows.length ? el("table", {class: "figures", id: "unmatched-table"}, el("tr", {},
    el("th", {text: "not joined"}), el("th", {text: "rows"}), el("th", {text: "names"})), ...rows) :
    el("p", {id: "unmatched-table", text: cols ? "every export row joined a planned point, every planned point " +
      "was measured" : ""}));
  return out;
}

function showResults() {
  const tol = state.session.tolerance_mm;
  for (const s of UI) {
    const done = state.done[s.id] || (s.id === "programs" && state.done.plan);
    const f = state.figures[s.id];
    $(`dot-${s.id}`).className = "dot" + (f && f.passes === false ? " fail" : done ? " done" : "");
    const figKey = JSON.stringify([f, tol]);   // drawn again only when it changed (the page polls while a job runs)
    if ($(`figure-${s.id}`).dataset.key !== figKey) {
      $(`figure-${s.id}`).dataset.key = figKey;
      $(`figure-${s.id}`).replaceChildren(...(f ? [figureBox(f, tol)] : []));
    }
    const job = logs[s.id], out = $(`output-${s.id}`);
    const kids = [];
    if (job) {
      if (!job.running && job.code !== 0 && job.error) showError(s.id, job.error);
      if (s.id.startsWith("import") && !job.running && job.code === 0) kids.push(...importTable(job.lines));
      kids.push(el("details", {open: ""}, el("summary", {class: "command", text: job.command}),
                   el("pre", {class: "log", id: `log-${s.id}`, text: job.lines.join("\n")})));
    }
    const stamp = Date.now();
    for (const img of done ? s.images || [] : []) {
      kids.push(el("img", {class: "result", src: `/files/${img}?t=${stamp}`}));
    }
    const key = JSON.stringify([done, job && [job.command, job.code, job.running, job.lines.length]]);
    if (drawn[s.id] !== key) {
      drawn[s.id] = key;
      out.replaceChildren(...kids);
      if (job) $(`command-${s.id}`).textContent = "";   // the job's own line shows the command
    }
  }
  if (state.done.scene && !$("scene-frame")) showScene();
}

function showScene() {
  const scene = () => `/files/scene.html?t=${Date.now()}`;
  const frame = el("iframe", {class: "scene", id: "scene-frame", src: scene()});
  const views = {iso: null, front: [0, 0, 1], side: [1, 0, 0], top: [0, 1, 0.01]};
  let wanted = "iso";
  const look = () => {   // the view asked for, once the scene's viewer is there (data-view says which is shown)
    const v = frame.contentWindow && frame.contentWindow.viewer, dir = views[wanted];
    frame.dataset.view = "";
    if (!v) return;   // the scene is loading: its load event comes back here
    if (dir) {
      const p = v.camera.position, d = Math.max(3, Math.hypot(p.x, p.y, p.z));   // meshcat's frame: y up
      v.set_property(["Cameras", "default", "rotated", "<object>"], "position", dir.map((c) => c * d));
      v.set_dirty();
    }
    frame.dataset.view = wanted;
  };
  frame.addEventListener("load", look);
  // a 3-D view draws all the time it is open, on the processor here (no graphics card in a
  // browser without one): the scene is closed when it has been off the screen for 5 s, and
  // opened again (in the view asked for last) when it comes back
  let closing = null;
  new IntersectionObserver(([e]) => {
    clearTimeout(closing);
    if (!e.isIntersecting) closing = setTimeout(() => { frame.src = "about:blank"; }, 5000);
    else if (frame.src.startsWith("about:")) { frame.dataset.view = ""; frame.src = scene(); }
  }).observe(frame);
  const bar = el("div", {class: "buttons"});
  for (const name of Object.keys(views)) {
    bar.append(button(`view-${name}`, name, () => {
      wanted = name;
      if (name === "iso") frame.src = scene(); else look();   // iso: the scene as it opens
    }));
  }
  $("scene").replaceChildren(bar, frame);
}

async function showTableMaps() {
  // each table the tables stage wrote (tables/tables.json) drawn as its map: the correction
  // of the output axis against the input axis's position, in the file's own units
  const out = $("result-tables"); out.textContent = "";
  const r = await fetch(`/files/tables/tables.json?t=${Date.now()}`);
  if (!r.ok) return;
  const tables = (await r.json()).tables || [];
  const NS = "http://www.w3.org/2000/svg", W = 240, H = 120, P = 30;
  const svg = (tag, attrs) => {
    const e = document.createElementNS(NS, tag);
    for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
    return e;
  };
  const grid = el("div", {class: "maps", id: "table-maps"});
  for (const t of tables) {
    const xs = t.values.map((_, k) => t.start + k * t.step), ys = t.values;
    const lo = Math.min(0, ...ys), hi = Math.max(0, ...ys), span = hi - lo || 1;
    const X = (x) => P + (W - P - 6) * (x - xs[0]) / ((xs[xs.length - 1] - xs[0]) || 1);
    const Y = (y) => H - 18 - (H - 30) * (y - lo) / span;
    const g = svg("svg", {width: W, height: H, viewBox: `0 0 ${W} ${H}`});
    g.append(svg("line", {x1: P, x2: W - 6, y1: Y(0), y2: Y(0), stroke: "#bbb"}),
             svg("polyline", {points: xs.map((x, k) => `${X(x)},${Y(ys[k])}`).join(" "), fill: "none",
                              stroke: "#1f3a5f", "stroke-width": 1.5}));
    const label = (x, y, text, anchor = "start") => {
      const e = svg("text", {x, y, "font-size": 10, fill: "#444", "text-anchor": anchor}); e.textContent = text;
      return e;
    };
    const f = (v) => (Math.abs(v) >= 100 ? v.toFixed(0) : v.toPrecision(3));
    g.append(label(2, Y(hi) + 4, f(hi)), label(2, Y(lo) + 4, f(lo)),
             label(P, H - 4, `${f(xs[0])}`), label(W - 6, H - 4, `${f(xs[xs.length - 1])} ${t.input_unit}`, "end"));
    grid.append(el("figure", {}, g, el("figcaption", {text: `${t.name}: ${t.output_axis} correction ` +
      `[${t.output_unit}] against ${t.input_axis} [${t.input_unit}], ${t.points} points`})));
  }
  out.append(el("h4", {text: `the tables the machine gets (${tables.length}, from tables/tables.json)`}), grid);
}

async function showPrograms() {
  const list = ["PLAN_840D.MPF", "O1000.nc", "plan.ngc", "plan.H", "plan.script", "VALID_840D.MPF", "O1001.nc",
                "validation.ngc"];
  const out = $("result-programs"); out.textContent = "";
  for (const name of list) {
    const r = await fetch(`/files/plan/${name}`);
    if (!r.ok) continue;
    const text = await r.text();
    out.append(el("details", {}, el("summary", {text: `plan/${name} (${text.split("\n").length} lines)`}),
                  el("pre", {class: "log", text: text.split("\n").slice(0, 80).join("\n")})));
  }
}

async function showProfile() {
  const p = await api("/api/profile");
  const out = $("result-profile"); out.textContent = "";
  const t = p.template; if (!t) return;
  const have = p.profile || {};
  out.append(el("ul", {class: "comments"}, ...(t.comment || []).map((c) => el("li", {text: c}))));
  const need = {};   // field -> "needed" or "optional", as the template's comments say
  for (const c of t.comment || []) { const m = /^(\w+) \((needed|optional)/.exec(c); if (m) need[m[1]] = m[2]; }
  for (const [axis, fields] of Object.entries(t.axes || {})) {
    const grid = el("div", {class: "fields"});
    for (const name of Object.keys(fields)) {
      const v = ((have.axes || {})[axis] || {})[name];
      grid.append(el("label", {for: `profile-${axis}-${name}`, text: name}),
                  el("input", {id: `profile-${axis}-${name}`, type: "text", size: 30, placeholder: need[name] || "",
                               value: v === undefined || v === null ? "" : String(v)}));
    }
    out.append(el("div", {class: "profile-axis"}, el("h4", {text: `axis ${axis}`}), grid));
  }
}

function typed(v) {
  if (v === "") return null;
  if (v === "true" || v === "false") return v === "true";
  return /^[-+]?\d*\.?\d+(e[-+]?\d+)?$/i.test(v) ? Number(v) : v;
}

async function saveProfile() {
  $("profile-saved").textContent = "";
  const p = await api("/api/profile");
  if (!p.template) { showError("profile", "make the template first"); return; }
  const prof = JSON.parse(JSON.stringify(p.template));
  delete prof.comment;
  for (const [axis, fields] of Object.entries(prof.axes)) {
    for (const name of Object.keys(fields)) fields[name] = typed($(`profile-${axis}-${name}`).value.trim());
  }
  await api("/api/profile", {profile: prof});
  $("error-profile").textContent = "";
  $("profile-saved").textContent = "saved profile.json (the tables stage reads it)";
  await loadSession();
}

async function writeRecord() {
  try { await api("/api/record", {}); } catch (e) { showError("report", e.message); return; }
  const text = await (await fetch(`/files/record.md?t=${Date.now()}`)).text();
  $("result-report").replaceChildren(el("pre", {class: "log", id: "record", text}));
  await refresh();
}

async function loadSession() {
  await refresh();
  const ses = state.session, stages = ses.stages || {};
  fillFields(UI[0], Object.assign({machine: ses.machine, tolerance_mm: ses.tolerance_mm}, ses.machine_options || {}));
  for (const s of UI) if (STAGES.includes(s.id)) fillFields(s, stages[s.id] || {});
  $("profile-controller").value = (stages.tables || {}).controller || "siemens-840d";
}

async function start() {
  const [choices, options] = await Promise.all([api("/api/choices"), api("/api/options")]);
  build();
  buildForms(options);
  for (const c of choices.controllers) $("profile-controller").append(el("option", {value: c, text: c}));
  const list = el("datalist", {id: "machines"});
  for (const m of choices.machines) list.append(el("option", {value: m}));
  document.body.append(list);
  $("machine-machine").setAttribute("list", "machines");
  await loadSession();
  if (state.done.plan) showPrograms();
  if (state.done.profile || state.done.plan) showProfile();
  if (state.done.tables) showTableMaps();
  if (state.job && state.job.running) poll();
  document.body.dataset.ready = "yes";
}

// results that are views of files refresh when their stage ends
const afterJob = {plan: showPrograms, profile: showProfile, tables: showTableMaps};
let lastEnded = null;
setInterval(() => {
  const j = state && state.job;
  if (j && !j.running && lastEnded !== j.command + j.elapsed_s) {
    lastEnded = j.command + j.elapsed_s;
    (afterJob[j.stage] || (() => null))();
  }
}, 500);
start();
