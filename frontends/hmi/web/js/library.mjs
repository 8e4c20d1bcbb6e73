// Program management and program definition. The form's layout (which field is on which
// sub-menu, its label and unit) is presentation; every check is the Rust code's: the server
// writes the fields as the program file and answers with each sub-menu's state, the problems
// by key path (shown on the field whose data-key it is) and the plan's derived values.
import { useState, useEffect, useRef } from "preact/hooks";
import { html, fmt, t, CmdButton } from "./ui.mjs";
import { api } from "./conn.mjs";

// Labels, units and choices stay English here (SECTIONS is built before the words are
// loaded); they are shown through t(), and LABELS at the bottom names each for the catalogue.
const num = (key, label, unit, args) => ({ key, label, unit, kind: "num", args });
const str = (key, label) => ({ key, label, kind: "str" });
const pick = (key, label, choices) => ({ key, label, kind: "str", choices });

export const SECTIONS = [
  ["workpiece", "WORKPIECE", [
    str("workpiece.name", "name"), num("workpiece.teeth", "teeth", ""), num("workpiece.module_mm", "normal module", "mm"),
    num("workpiece.helix_deg", "helix angle", "deg"), pick("workpiece.helix_hand", "helix hand", ["right", "left"]),
    num("workpiece.face_width_mm", "face width", "mm"), num("workpiece.outside_diameter_mm", "outside diameter", "mm"),
    num("workpiece.height_above_table_mm", "height above the table", "mm"), num("workpiece.allowance_mm", "approach/exit allowance", "mm"),
    num("workpiece.crowning.height_mm", "crowning: arc height (or radius below)", "mm"), num("workpiece.crowning.radius_mm", "crowning: radius", "mm"),
    ...[0, 1, 2, 3, 4, 5].flatMap((i) => [
      num(`workpiece.contour[${i}][0]`, "contour point {0}: along the face", "mm", [i + 1]),
      num(`workpiece.contour[${i}][1]`, "contour point {0}: X offset", "mm", [i + 1]),
    ]),
  ]],
  ["tool", "TOOL", [
    str("tool.library", "library tool (or the fields below)"), pick("tool.kind", "kind", ["hob", "disk"]),
    num("tool.module_mm", "module", "mm"), num("tool.pressure_angle_deg", "pressure angle", "deg"), num("tool.starts", "starts", ""),
    num("tool.lead_angle_deg", "lead angle", "deg"), pick("tool.hand", "hand", ["right", "left"]),
    num("tool.outside_diameter_mm", "outside diameter", "mm"), num("tool.length_mm", "length", "mm"), num("tool.gashes", "gashes", ""),
  ]],
  ["cycle", "CYCLE", [
    pick("cycle.kind", "cycle", ["radial-axial", "radial-plunge", "tooth-by-tooth"]), pick("cycle.start", "start", ["top", "bottom"]),
    pick("cycle.method", "method", ["climb", "conventional"]), pick("cycle.mode", "mode", ["automatic", "single"]),
    num("cycle.single_depth_mm", "single pass depth", "mm"),
  ]],
  ["strategy", "STRATEGY AND PARAMETERS", [
    num("strategy.total_depth_mm", "total depth", "mm"), num("strategy.rough_passes", "rough passes", ""),
    num("strategy.finish_allowance_mm", "finishing allowance", "mm"), num("strategy.rough_depths_mm[0]", "depth of rough pass 1", "mm"),
    num("strategy.rough_depths_mm[1]", "depth of rough pass 2", "mm"), num("strategy.rough_depths_mm[2]", "depth of rough pass 3", "mm"),
    num("strategy.retract_mm", "retract", "mm"),
    num("strategy.rough.cutting_speed_m_min", "rough: cutting speed v_c", "m/min"), num("strategy.rough.feed_mm_per_rev", "rough: feed", "mm/rev"),
    num("strategy.finish.cutting_speed_m_min", "finish: cutting speed v_c", "m/min"), num("strategy.finish.feed_mm_per_rev", "finish: feed", "mm/rev"),
  ]],
];

const KNOWN = new Set(SECTIONS.flatMap(([, , fs]) => fs.map((f) => f.key)));

export function Programs({ conn, program, setProgram, go }) {
  const [list, setList] = useState(null);
  const [name, setName] = useState("");
  const [msg, setMsg] = useState(null);
  const refresh = () => api("GET", "/api/programs").then(setList);
  useEffect(() => { refresh(); }, []);
  const act = async (method, path, body, after) => {
    const r = await api(method, path, body);
    setMsg(r.ok ? { ok: true, text: t("done") } : { ok: false, text: r.refused });
    if (r.ok && after) after();
    refresh();
  };
  if (!list) return html`<p>${t("reading the library...")}</p>`;
  if (!list.ok) return html`<p class="bad">${list.refused}</p>`;
  return html`<section class="card"><h2>${t("Programs")} <small>${list.dir}</small></h2>
    <div class="row">${t("name")} <input value=${name} data-testid="program-name" onInput=${(e) => setName(e.target.value)} placeholder=${t("e.g. {0}", "spur-z17-m5")} />
      <button class="key primary" data-testid="program-new" disabled=${!name} onClick=${() => { setProgram(null); go("definition"); sessionStorage.setItem("newName", name); }}>${t("NEW")}</button>
      <button class="key" disabled=${!name || !program} onClick=${() => act("POST", `/api/programs/${encodeURIComponent(program)}/copy`, { to: name })}>${t("COPY SELECTED")}</button>
      <button class="key" disabled=${!name || !program} onClick=${() => act("POST", `/api/programs/${encodeURIComponent(program)}/rename`, { to: name }, () => setProgram(name))}>${t("RENAME SELECTED")}</button></div>
    ${msg ? html`<p class=${msg.ok ? "ok" : "bad"} data-testid="library-answer">${msg.text}</p>` : ""}
    <table class="grid programs">${list.entries.map((e) => html`<tr class=${e.name === program ? "selected" : ""} data-program=${e.name}>
      <td><button class="key small" onClick=${() => setProgram(e.name)}>${e.name === program ? "✓ " : ""}${e.name}</button></td>
      <td class=${e.valid ? "ok" : "bad"}>${e.valid ? t("valid") : e.problem}</td>
      <td><button class="key small" onClick=${() => { setProgram(e.name); go("definition"); }}>${t("EDIT")}</button>
        <${CmdButton} conn=${conn} op="load" fields=${{ program: e.name }} label=${t("LOAD")} cls="small" testid=${`load-${e.name}`} disabled=${!e.valid} />
        <button class="key small stop" onClick=${() => confirm(t("Delete {0}?", e.name)) && act("DELETE", `/api/programs/${encodeURIComponent(e.name)}`, undefined, () => e.name === program && setProgram(null))}>${t("DELETE")}</button></td></tr>`)}
    </table>${list.entries.length === 0 ? html`<p class="hint">${t("The library is empty: NEW starts a program.")}</p>` : ""}</section>`;
}

function Field({ f, value, problem, onInput }) {
  const cls = `field ${problem ? "problem" : ""}`;
  const input = f.choices
    ? html`<select data-key=${f.key} value=${value} onChange=${(e) => onInput(f.key, e.target.value)}><option value=""></option>${f.choices.map((c) => html`<option value=${c}>${t(c)}</option>`)}</select>`
    : html`<input data-key=${f.key} value=${value} inputmode=${f.kind === "num" ? "decimal" : "text"} onInput=${(e) => onInput(f.key, e.target.value)} />`;
  return html`<label class=${cls}><span>${t(f.label, ...(f.args || []))}</span>${input}<span class="unit">${f.unit ? t(f.unit) : ""}</span>${problem ? html`<em class="why" data-problem=${f.key}>${problem}</em>` : ""}</label>`;
}

/** A sketch of the X shape along the face: crowning arc and contour points, X offsets
 *  exaggerated so that hundredths of a mm show; from the typed values, drawn only. */
function ShapeSketch({ values }) {
  const w = Number(values["workpiece.face_width_mm"]);
  const h = Number(values["workpiece.crowning.height_mm"] || 0);
  const pts = [0, 1, 2, 3, 4, 5]
    .map((i) => [values[`workpiece.contour[${i}][0]`], values[`workpiece.contour[${i}][1]`]])
    .filter(([a, b]) => a !== undefined && a !== "" && b !== undefined && b !== "")
    .map(([a, b]) => [Number(a), Number(b)]);
  if (!(w > 0)) return html`<p class="hint">${t("The sketch of the shape appears with the face width.")}</p>`;
  const n = 40, line = [];
  for (let k = 0; k <= n; k++) {
    const y = (w * k) / n;
    const crown = h ? h * (1 - (2 * y / w - 1) ** 2) : 0;
    line.push([y, crown]);
  }
  const all = [...line.map((p) => p[1]), ...pts.map((p) => p[1]), 0];
  const span = Math.max(1e-6, Math.max(...all) - Math.min(...all));
  const lo = Math.min(...all);
  const X = (y) => 20 + (360 * y) / w, Y = (o) => 130 - (100 * (o - lo)) / span;
  return html`<svg class="sketch" viewBox="0 0 400 150" data-testid="shape-sketch">
    <line x1="20" y1=${Y(0)} x2="380" y2=${Y(0)} stroke="#556" />
    <polyline fill="none" stroke="#50d0ff" stroke-width="2" points=${line.map(([y, o]) => `${X(y)},${Y(o)}`).join(" ")} />
    ${pts.length ? html`<polyline fill="none" stroke="#ffc040" stroke-width="2" points=${pts.map(([y, o]) => `${X(y)},${Y(o)}`).join(" ")} />` : ""}
    ${pts.map(([y, o]) => html`<circle cx=${X(y)} cy=${Y(o)} r="4" fill="#ffc040" />`)}
    <text x="20" y="146" fill="#9fb0c0" font-size="12">${t("face {0}", 0)}</text><text x="330" y="146" fill="#9fb0c0" font-size="12">${w} mm</text>
    <text x="24" y="14" fill="#9fb0c0" font-size="12">${t("X offset, {0} um full height", (span * 1000).toFixed(0))}</text></svg>`;
}

/** The tool library in the TOOL sub-menu: each tool valid or not, its usage; pick one for
 *  the program, delete one, or store the program's own tool as a new one. */
function ToolLibrary({ values, setValues, fields }) {
  const [list, setList] = useState(null);
  const [usage, setUsage] = useState({});
  const [name, setName] = useState("");
  const [msg, setMsg] = useState(null);
  const refresh = async () => {
    const r = await api("GET", "/api/tools");
    setList(r);
    const u = {};
    for (const e of r.entries || []) {
      const tool = await api("GET", `/api/tools/${encodeURIComponent(e.name)}`);
      u[e.name] = tool.usage;
    }
    setUsage(u);
  };
  useEffect(() => { refresh(); }, []);
  const pickTool = (n) => {
    const v = { ...values };
    for (const k of Object.keys(v)) if (k.startsWith("tool.")) delete v[k];
    v["tool.library"] = n;
    setValues(v);
  };
  const act = async (method, path, body) => {
    const r = await api(method, path, body);
    setMsg(r.ok ? { ok: true, text: t("done") } : { ok: false, text: r.refused });
    refresh();
  };
  if (!list) return html`<p class="hint">${t("reading the tool library...")}</p>`;
  return html`<div class="tools" data-testid="tool-library"><h3>${t("Tool library")}</h3>
    <table class="grid">${(list.entries || []).map((e) => html`<tr data-tool=${e.name}>
      <td>${e.name}</td><td class=${e.valid ? "ok" : "bad"}>${e.valid ? t("valid") : e.problem}</td>
      <td class="small">${usage[e.name] ? (usage[e.name].last_used_utc
        ? t("{0} passes, {1} m in the cut, last {2}", usage[e.name].passes_cut, Number(usage[e.name].y_travel_in_cut_m).toFixed(2), usage[e.name].last_used_utc)
        : t("{0} passes, {1} m in the cut", usage[e.name].passes_cut, Number(usage[e.name].y_travel_in_cut_m).toFixed(2))) : ""}</td>
      <td><button class="key small" disabled=${!e.valid} onClick=${() => pickTool(e.name)}>${t("PICK")}</button>
        <button class="key small stop" onClick=${() => confirm(t("Delete the tool {0}?", e.name)) && act("DELETE", `/api/tools/${encodeURIComponent(e.name)}`)}>${t("DELETE")}</button></td></tr>`)}</table>
    ${list.entries && list.entries.length === 0 ? html`<p class="hint">${t("No tools in the library yet.")}</p>` : ""}
    <div class="row">${t("new tool")} <input value=${name} data-testid="tool-name" onInput=${(e) => setName(e.target.value)} />
      <button class="key" data-testid="tool-save" disabled=${!name} onClick=${() => act("POST", "/api/tool-from-form", { name, fields: fields() })}>${t("STORE THE FIELDS ABOVE AS A LIBRARY TOOL")}</button></div>
    ${msg ? html`<p class=${msg.ok ? "ok" : "bad"} data-testid="tool-answer">${msg.text}</p>` : ""}</div>`;
}

function Derived({ plan }) {
  if (!plan) return html`<p class="hint">${t("The plan appears when every sub-menu is green.")}</p>`;
  return html`<table class="kv" data-testid="derived">
    <tr><td>${t("gearbox ratio")}</td><td>${fmt(plan.egb_ratio, 6)}</td></tr>
    <tr><td>${t("differential")}</td><td>${fmt(plan.differential_deg_per_mm, 6)} ${t("deg/mm")}</td></tr>
    <tr><td>${t("hob swivel A")}</td><td>${fmt(plan.hob_swivel_deg, 3)} ${t("deg")} ${plan.hob_swivel_sense ? t(plan.hob_swivel_sense) : ""}</td></tr>
    ${plan.passes.map((p, i) => html`<tr><td>${t("pass {0} ({1})", i + 1, t(p.kind))}</td><td>${t("depth {0} mm", fmt(p.depth_mm, 3))}, v<sub>c</sub> ${t("{0} m/min, hob {1} rpm, table {2} rpm, feed {3} mm/rev = {4} mm/min, Y {5} → {6} mm (stroke {7} mm), {8} s",
      fmt(p.cutting_speed_m_min, 1), fmt(p.spindle_rpm, 1), fmt(p.table_rpm, 2), fmt(p.feed_mm_per_rev, 2), fmt(p.axial_feed_mm_min, 1),
      fmt(p.y_start_mm, 1), fmt(p.y_end_mm, 1), fmt(Math.abs(p.y_end_mm - p.y_start_mm), 1), fmt(p.pass_time_s, 0))}</td></tr>`)}
    <tr><td>${t("cycle time")}</td><td data-testid="cycle-time">${fmt(plan.total_time_s / 60, 1)} min</td></tr>
    ${plan.warnings.map((w) => html`<tr><td>${t("warning")}</td><td class="warn">${w}</td></tr>`)}</table>`;
}

export function Definition({ conn, program, setProgram, go }) {
  const [name, setName] = useState(program || sessionStorage.getItem("newName") || "");
  const [isNew, setIsNew] = useState(!program);
  const [values, setValues] = useState({});
  const [extra, setExtra] = useState([]); // fields of the file the form has no place for: kept as they are
  const [section, setSection] = useState("workpiece");
  const [check, setCheck] = useState(null);
  const [saved, setSaved] = useState(null);
  const timer = useRef(null);
  useEffect(() => {
    if (!program) return;
    api("GET", `/api/form/${encodeURIComponent(program)}`).then((r) => {
      if (!r.ok) return setSaved({ ok: false, text: r.refused });
      const v = {}, x = [];
      for (const f of r.fields) (KNOWN.has(f.key) ? (v[f.key] = f.text) : x.push(f));
      setValues(v); setExtra(x); setIsNew(false); setName(program);
    });
  }, [program]);
  const fields = () => [
    ...SECTIONS.flatMap(([, , fs]) => fs.map((f) => ({ key: f.key, kind: f.kind, text: values[f.key] || "" }))),
    ...extra,
  ];
  useEffect(() => {
    clearTimeout(timer.current);
    timer.current = setTimeout(() => api("POST", "/api/check", { fields: fields() }).then(setCheck), 250);
  }, [values]);
  const set = (k, v) => setValues({ ...values, [k]: v });
  // A problem of a whole contour point (workpiece.contour[2]) shows on both its fields.
  const covers = (pk, k) => pk === k || (pk !== "" && k.startsWith(`${pk}[`));
  const problemOf = (k) => check && (check.problems || []).filter((p) => covers(p.key, k)).map((p) => p.message).join("; ");
  const state = (s) => (check && check.sections ? check.sections[s] : "missing");
  const allGreen = check && check.plan && SECTIONS.every(([s]) => state(s) === "ok");
  const save = async () => {
    const r = await api("POST", "/api/save", { name, new: isNew, fields: fields() });
    setSaved({ ok: r.ok, text: r.ok ? t("saved as {0}", name) : r.refused, problems: r.problems });
    if (r.ok) { setIsNew(false); setProgram(name); sessionStorage.removeItem("newName"); }
  };
  const [, , current] = SECTIONS.find(([s]) => s === section);
  const unplaced = check ? (check.problems || []).filter((p) => ![...KNOWN].some((k) => covers(p.key, k))) : [];
  return html`<section class="definition">
    <div class="row submenus">${SECTIONS.map(([s, label]) => html`<button class=${`key submenu ${state(s)} ${s === section ? "on" : ""}`} data-section=${s} data-state=${state(s)} onClick=${() => setSection(s)}>${t(label)}</button>`)}</div>
    <div class="grid2">
      <div class="card"><h2>${isNew ? t("New program") : t("Program")} <input value=${name} data-testid="definition-name" onInput=${(e) => setName(e.target.value)} /></h2>
        ${current.map((f) => html`<${Field} f=${f} value=${values[f.key] || ""} problem=${problemOf(f.key)} onInput=${set} />`)}
        ${section === "workpiece" ? html`<${ShapeSketch} values=${values} />` : ""}
        ${section === "tool" ? html`<${ToolLibrary} values=${values} setValues=${setValues} fields=${fields} />` : ""}
        ${unplaced.length ? html`<div class="bad" data-testid="other-problems">${unplaced.map((p) => html`<div>${p.key || t("program")}: ${p.message}</div>`)}</div>` : ""}
        <div class="row"><button class="key primary" data-testid="save" onClick=${save} disabled=${!name}>${t("SAVE")}</button>
          <button class="key" data-testid="go-single" disabled=${!allGreen || !program} onClick=${() => go("single")}>${t("SINGLE MODE")}</button>
          <button class="key" data-testid="go-automatic" disabled=${!allGreen || !program} onClick=${() => go("automatic")}>${t("AUTOMATIC")}</button></div>
        ${saved ? html`<p class=${saved.ok ? "ok" : "bad"} data-testid="save-answer">${saved.text}</p>` : ""}</div>
      <div class="card"><h2>${t("Derived values")}</h2><${Derived} plan=${check && check.plan} /></div>
    </div></section>`;
}

// Labels of the structures above, for the catalogue's check: the sub-menus, the fields, their
// word units and choices (SECTIONS), and the pass kinds and hands the plan sends (Derived).
export const LABELS = () => [
  t("WORKPIECE"), t("TOOL"), t("CYCLE"), t("STRATEGY AND PARAMETERS"),
  t("name"), t("teeth"), t("normal module"), t("helix angle"), t("helix hand"), t("face width"), t("outside diameter"),
  t("height above the table"), t("approach/exit allowance"), t("crowning: arc height (or radius below)"), t("crowning: radius"),
  t("contour point {0}: along the face"), t("contour point {0}: X offset"),
  t("library tool (or the fields below)"), t("kind"), t("module"), t("pressure angle"), t("starts"), t("lead angle"), t("hand"),
  t("length"), t("gashes"),
  t("cycle"), t("start"), t("method"), t("mode"), t("single pass depth"),
  t("total depth"), t("rough passes"), t("finishing allowance"), t("depth of rough pass 1"), t("depth of rough pass 2"),
  t("depth of rough pass 3"), t("retract"), t("rough: cutting speed v_c"), t("rough: feed"), t("finish: cutting speed v_c"), t("finish: feed"),
  t("deg"), t("mm/rev"),
  t("right"), t("left"), t("hob"), t("disk"), t("radial-axial"), t("radial-plunge"), t("tooth-by-tooth"), t("top"), t("bottom"),
  t("climb"), t("conventional"), t("automatic"), t("single"),
  t("rough"), t("finish"),
];
