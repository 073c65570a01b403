// The vecpin workbench page: one section per stage of the day. Every value here is a choice
// the server keeps in the folder's session.json; every result is a file a vecpin command wrote.
"use strict";

// field kinds: text, int, number (kept as typed when it is not a number: the command says why),
// list; (a list split at ';'), list, (split at ','), words (split at spaces), bool (a switch), select
const UI = [
  {id: "machine", title: "Machine", what: "The machine (a bundled name or a URDF path), its axes and frames, and the " +
    "volumetric error you accept after compensation (mm).", run: "Show axes and frames",
   fields: [["machine", "machine (bundled name or URDF path)", "text"],
            ["tolerance_mm", "tolerance after compensation, mm", "number"]]},
  {id: "plan", title: "Plan", what: "Points, zones, tracker place; the line of sight is tested unless switched off.",
   run: "Plan", images: ["plan/plan.png"],
   fields: [["points", "points (commands)", "int"], ["order", "order (or auto)", "text"],
            ["tracker", "tracker X,Y,Z (mm)", "text"],
            ["exclude", "exclusion zones (AXIS=LO:HI, ';' between)", "list;"],
            ["repeat", "repeated points: POINTS TIMES", "words"], ["candidates", "candidate commands", "int"],
            ["validation-count", "validation commands", "int"],
            ["dialect", "program dialects (',' between)", "list,"], ["no-sight", "no line-of-sight test", "bool"]]},
  {id: "programs", title: "Programs", what: "The measurement and validation programs the plan wrote (dialects: the " +
   "plan's field above).", view: "programs"},
  {id: "import", title: "Import the tracker export", run: "Import", what: "The tracker software's export joined to " +
   "the plan by point name; the column mapping and any unmatched rows are in the output.",
   fields: [["export", "tracker export (path)", "text"], ["columns", "column mapping FIELD=COLUMN,...", "text"],
            ["units", "units of x, y, z", "select", ["", "auto", "mm", "in", "m"]],
            ["ignore-unmatched", "skip rows not in the plan", "bool"]]},
  {id: "assess", title: "Assess", run: "Assess", what: "Is compensation worth it? Repeatability, drift, the " +
   "instrument's floor and the uncompensated error.", fields: []},
  {id: "fit", title: "Fit", run: "Fit", what: "The model the data choose (or the one you fix), with its held-out " +
   "figures.", scene: true,
   fields: [["model", "model", "select", ["", "auto", "6dof", "ap"]],
            ["basis", "basis", "select", ["", "auto", "chebyshev", "fourier", "fourier_trend", "spline", "pspline"]],
            ["order", "order (or auto)", "text"]]},
  {id: "evaluate", title: "Evaluate", run: "Evaluate", what: "The model's residuals on the campaign.", fields: []},
  {id: "diagnose", title: "Diagnose", run: "Diagnose", what: "What the model does not explain: the three sentences " +
   "first, then the ambiguity and what to measure next.", fields: [["effects", "candidate effects", "text"]]},
  {id: "profile", title: "Controller profile", what: "What the controller's files need from the machine: fill in " +
   "every null the template marks as needed.", view: "profile"},
  {id: "tables", title: "Tables and files", run: "Write the tables", what: "What the machine gets, in the " +
   "controller's format, and the error it keeps in the part's frame.",
   fields: [["controller", "controller", "select", ["", "siemens-840d", "siemens-828d", "fanuc-30i", "linuxcnc",
             "beckhoff", "heidenhain", "iso230", "generic"]],
            ["profile", "controller profile (the profile stage writes profile.json)", "text"],
            ["method", "subset method", "select", ["", "exact", "ga", "heuristic"]],
            ["table-points", "points per table", "int"]]},
  {id: "import_before", title: "Import the validation run without the tables", run: "Import",
   what: "The tracker export of the plan's validation program run without the tables, joined to the plan's " +
   "validation run (plan/validation.csv).",
   fields: [["export", "tracker export (path)", "text"], ["columns", "column mapping FIELD=COLUMN,...", "text"]]},
  {id: "import_after", title: "Import the validation run with the tables", run: "Import",
   what: "The same program run again with the tables loaded, its tracker export.",
   fields: [["export", "tracker export (path)", "text"], ["columns", "column mapping FIELD=COLUMN,...", "text"]]},
  {id: "verify", title: "Verify", run: "Verify", images: ["verify/verify.png"], what: "The validation run without " +
   "and with the tables, in the part's frame.",
   fields: [["before", "run without the tables (campaign CSV; empty: the one imported above)", "text"],
            ["after", "run with the tables (campaign CSV; empty: the one imported above)", "text"]]},
  {id: "report", title: "Compensation record", what: "What was measured, fitted, written and verified, with " +
   "versions (ISO/TR 16907 clauses 11 and 12).", view: "report"},
];
const STAGES = ["plan", "import", "assess", "fit", "evaluate", "diagnose", "tables", "import_before", "import_after",
                "verify"];
let state = null, polling = null, logs = {}, drawn = {};

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

function build() {
  const main = $("stages"); main.textContent = "";
  UI.forEach((s, k) => {
    $("nav").append(el("a", {href: "#stage-" + s.id, id: "nav-" + s.id}, el("span", {class: "dot", id: "dot-" + s.id}),
                       `${k + 1} ${s.title}`));
    const sec = el("section", {id: "stage-" + s.id}, el("h2", {text: `${k + 1}. ${s.title}`}),
                   el("p", {class: "what", text: s.what}));
    if (s.fields) {
      const grid = el("div", {class: "fields"});
      for (const [name, label, kind, options] of s.fields) {
        const id = `${s.id}-${name}`;
        let input;
        if (kind === "select") {
          input = el("select", {id});
          for (const o of options) input.append(el("option", {value: o, text: o || "(default)"}));
        } else if (kind === "bool") input = el("input", {id, type: "checkbox"});
        else input = el("input", {id, type: "text", size: 50});
        grid.append(el("label", {for: id, text: label}), input);
      }
      if (STAGES.includes(s.id)) {
        grid.append(el("label", {for: `${s.id}-more`, text: "other options (JSON object)"}),
                    el("input", {id: `${s.id}-more`, type: "text", size: 50, placeholder: "{}"}));
      }
      sec.append(grid);
    }
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

function readFields(s) {
  const out = {};
  for (const [name, , kind] of s.fields || []) {
    const input = $(`${s.id}-${name}`);
    if (kind === "bool") { if (input.checked) out[name] = true; continue; }
    const v = input.value.trim();
    if (v === "") continue;
    if (kind === "int" || kind === "number") out[name] = /^[-+]?\d*\.?\d+(e[-+]?\d+)?$/i.test(v) ? Number(v) : v;
    else if (kind === "list;") out[name] = v.split(";").map((t) => t.trim()).filter(Boolean);
    else if (kind === "list,") out[name] = v.split(",").map((t) => t.trim()).filter(Boolean);
    else if (kind === "words") out[name] = v.split(/\s+/).map((t) => (/^\d+$/.test(t) ? Number(t) : t));
    else out[name] = v;
  }
  const more = $(`${s.id}-more`);
  if (more && more.value.trim()) Object.assign(out, JSON.parse(more.value));
  return out;
}

function fillFields(s, values) {
  const known = new Set((s.fields || []).map((f) => f[0]));
  for (const [name, , kind] of s.fields || []) {
    const input = $(`${s.id}-${name}`), v = values[name];
    if (kind === "bool") input.checked = !!v;
    else if (v === undefined || v === null) input.value = "";
    else if (Array.isArray(v)) input.value = v.join(kind === "list;" ? "; " : kind === "words" ? " " : ",");
    else input.value = String(v);
  }
  const more = $(`${s.id}-more`);
  if (more) {
    const rest = Object.fromEntries(Object.entries(values).filter(([k]) => !known.has(k)));
    more.value = Object.keys(rest).length ? JSON.stringify(rest) : "";
  }
}

async function saveStage(id) {
  const s = UI.find((u) => u.id === id);
  $(`error-${id}`).textContent = "";
  let fields;
  try { fields = readFields(s); } catch (e) { showError(id, "other options: " + e.message); return false; }
  try {
    const r = await api(`/api/stage/${id}`, {fields});
    $(`command-${id}`).textContent = r.command || "";
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
  } else if (id !== "scene" && !(await saveStage(id))) { document.body.dataset.action = "done"; return; }
  $(`error-${owner}`).textContent = "";
  try { await api(`/api/run/${id}`, {}); } catch (e) {
    showError(owner, e.message); document.body.dataset.action = "done"; return;
  }
  poll();
}

function poll() {
  clearTimeout(polling);
  polling = setTimeout(async () => {
    await refresh();
    if (state.job && state.job.running) poll(); else document.body.dataset.action = "done";
  }, 300);
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

function figureBox(f, tol) {
  const mm = (v) => (v === null || v === undefined ? "-" : `${v.toFixed(4)} mm`);
  const verdict = f.passes === true ? "pass" : f.passes === false ? "fail" : "";
  const box = el("div", {class: "figure " + verdict});
  if (f.headline) box.append(el("ul", {}, ...f.headline.map((t) => el("li", {text: t}))));
  box.append(el("span", {class: "badge " + verdict, text: f.passes === true ? "PASS" : f.passes === false ? "FAIL" :
    "not judged"}), ` ${f.what}: ${mm(f.value_mm)}` + (f.judged ? `, tolerance ${tol ? mm(tol) : "not stated"}` : "") +
    (f.noise_mm ? `, instrument noise ${mm(f.noise_mm)}` : "") + (f.verdict ? `, verdict: ${f.verdict}` : "") +
    (f.rows !== undefined && f.rows !== null ? `, ${f.rows} rows` : ""));
  return box;
}

function showResults() {
  const tol = state.session.tolerance_mm;
  for (const s of UI) {
    const done = state.done[s.id] || (s.id === "programs" && state.done.plan);
    const f = state.figures[s.id];
    $(`dot-${s.id}`).className = "dot" + (f && f.passes === false ? " fail" : done ? " done" : "");
    $(`figure-${s.id}`).replaceChildren(...(f ? [figureBox(f, tol)] : []));
    const job = logs[s.id], out = $(`output-${s.id}`);
    const kids = [];
    if (job) {
      if (!job.running && job.code !== 0 && job.error) showError(s.id, job.error);
      kids.push(el("div", {class: "command", text: job.command}),
                el("pre", {class: "log", id: `log-${s.id}`, text: job.lines.join("\n")}));
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
  const frame = el("iframe", {class: "scene", id: "scene-frame", src: `/files/scene.html?t=${Date.now()}`});
  const views = {iso: null, front: [0, 0, 1], side: [1, 0, 0], top: [0, 1, 0.01]};
  const bar = el("div", {class: "buttons"});
  for (const [name, dir] of Object.entries(views)) {
    bar.append(button(`view-${name}`, name, () => {
      if (!dir) { frame.src = `/files/scene.html?t=${Date.now()}`; return; }
      const v = frame.contentWindow.viewer, p = v.camera.position;
      const d = Math.max(3, Math.hypot(p.x, p.y, p.z));   // meshcat's frame: y up; the machine's z is y there
      v.set_property(["Cameras", "default", "rotated", "<object>"], "position", dir.map((c) => c * d));
      v.set_dirty();
    }));
  }
  $("scene").replaceChildren(bar, frame);
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
  fillFields(UI[0], {machine: ses.machine, tolerance_mm: ses.tolerance_mm});
  for (const s of UI) if (STAGES.includes(s.id)) fillFields(s, stages[s.id] || {});
  $("profile-controller").value = (stages.tables || {}).controller || "siemens-840d";
}

async function start() {
  const choices = await api("/api/choices");
  build();
  for (const c of choices.controllers) $("profile-controller").append(el("option", {value: c, text: c}));
  const list = el("datalist", {id: "machines"});
  for (const m of choices.machines) list.append(el("option", {value: m}));
  document.body.append(list);
  $("machine-machine").setAttribute("list", "machines");
  await loadSession();
  if (state.done.plan) showPrograms();
  if (state.done.profile || state.done.plan) showProfile();
  if (state.job && state.job.running) poll();
  document.body.dataset.ready = "yes";
}

// results that are views of files refresh when their stage ends
const afterJob = {plan: showPrograms, profile: showProfile};
let lastEnded = null;
setInterval(() => {
  const j = state && state.job;
  if (j && !j.running && lastEnded !== j.command + j.elapsed_s) {
    lastEnded = j.command + j.elapsed_s;
    (afterJob[j.stage] || (() => null))();
  }
}, 500);
start();
