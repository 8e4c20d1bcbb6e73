// The machine's screens: power-up, jog and set-up, single mode with the span measurement,
// automatic, the cut report, alarms, diagnostics. Values come from the loop's frames; every
// button is one loop command whose answer (accepted, or the loop's refusal) is shown.
import { Component } from "preact";
import { useState, useEffect, useRef } from "preact/hooks";
import { html, fmt, t, CmdButton, allows } from "./ui.mjs";
import { HoldKey, RENEW_MS } from "./hold.mjs";
import { SyncPlot } from "./plot.mjs";
import { api } from "./conn.mjs";

const sig = (s, list, name) => {
  const x = s && s[list].find((v) => v.name === name);
  return x ? x.active : undefined;
};

function Check({ ok, label, detail, testid }) {
  const cls = ok === undefined ? "unknown" : ok ? "ok" : "bad";
  return html`<li class=${`check ${cls}`} data-testid=${testid}><span class="mark">${ok === undefined ? "?" : ok ? "✓" : "✗"}</span> ${label}${detail ? html` <small>${detail}</small>` : ""}</li>`;
}

export function PowerUp({ conn }) {
  const s = conn.frame && conn.frame.state;
  const on = (l, n) => sig(s, l, n);
  const drives = (a) => s && s.drives_enabled.includes(a);
  return html`<section class="grid2">
    <div class="card"><h2>${t("Safety chain")}</h2>
      <p class="hint">${t("Its reset needs: VFD ready, the PC's reset relay on, lube and coolant pumps off, e-stops released, then the RESET button on the panel.")}</p>
      <ul class="checks">
        <${Check} ok=${on("inputs", "safety_chain_closed")} label=${t("safety chain closed")} testid="chain" />
        <${Check} ok=${s && !on("inputs", "estop_pressed")} label=${t("e-stop released")} />
        <${Check} ok=${on("inputs", "vfd_ready")} label=${t("VFD ready")} />
        <${Check} ok=${s && !on("inputs", "vfd_fault")} label=${t("no VFD fault")} />
        <${Check} ok=${on("outputs", "pc_reset_relay")} label=${t("PC reset relay on")} />
        <${Check} ok=${on("outputs", "pc_ok_relay")} label=${t("PC-OK relay on (controller healthy)")} />
        <${Check} ok=${s && !on("outputs", "coolant_pump")} label=${t("coolant pump off")} />
        <${Check} ok=${s && s.io_valid} label=${t("I/O coupler answering")} />
      </ul></div>
    <div class="card"><h2>${t("Lubrication and drives")}</h2>
      <ul class="checks">
        <li class="check info" data-testid="lube">lube pump <b>${s ? (on("outputs", "lube_pump") ? "running" : "off") : "-"}</b>, pressure switch <b>${s ? (on("inputs", "lube_pressure_ok") ? "on" : "off") : "-"}</b>
          <small>the pump runs at power-up and after every 5 m of travel; its pressure must come within the machine file's time, else the LUBE alarm</small></li>
        <${Check} ok=${drives("B")} label=${t("drive B (table) enabled")} testid="drive-B" />
        <${Check} ok=${drives("X")} label=${t("drive X (radial) enabled")} testid="drive-X" />
        <${Check} ok=${drives("Y")} label=${t("drive Y (axial) enabled")} testid="drive-Y" />
      </ul></div>
    <div class="card wide"><h2>${t("Referencing")}</h2>
      <p class="hint">${t("X and Y find their home switch and index pulse (CiA 402 homing). Until then they jog only slowly, and no cycle starts.")}</p>
      <ul class="checks">
        <${Check} ok=${s && s.referenced.x} label=${t("X referenced")} testid="ref-x" />
        <${Check} ok=${s && s.referenced.y} label=${t("Y referenced")} testid="ref-y" />
      </ul>
      <div class="row">
        <${CmdButton} conn=${conn} op="home" fields=${{ axis: "x" }} label=${t("HOME X")} testid="home-x" />
        <${CmdButton} conn=${conn} op="home" fields=${{ axis: "y" }} label=${t("HOME Y")} testid="home-y" />
        <${CmdButton} conn=${conn} op="home" fields=${{ axis: "all" }} label=${t("HOME ALL")} cls="primary" testid="home-all" />
      </div></div>
  </section>`;
}

const STEPS = [0.001, 0.01, 0.1, 1];

const mmss = (t) => `${Math.floor(t / 60)}:${String(Math.floor(t % 60)).padStart(2, "0")}`;

export function Jog({ conn, program }) {
  const s = conn.frame && conn.frame.state;
  const [speed, setSpeed] = useState(300);
  const [step, setStep] = useState(0.1);
  const [rpm, setRpm] = useState(20);
  const [plan, setPlan] = useState(null);
  useEffect(() => {
    if (!program) return;
    api("GET", `/api/plan/${encodeURIComponent(program)}`).then((r) => setPlan(r.ok ? r.plan : null));
  }, [program]);
  const unref = conn.hello && conn.hello.jog.unreferenced_mm_min;
  const pos = (label, v, unit, testid) => html`<div class="pos"><span class="label">${label}</span><b data-testid=${testid}>${s ? fmt(v, 3) : "-"}</b> ${unit}</div>`;
  return html`<section class="grid2">
    <div class="card"><h2>${t("Positions")}</h2>
      ${pos("X", s && s.x_mm.act, "mm", "pos-x")}${pos("Y", s && s.y_mm.act, "mm", "pos-y")}
      ${pos("B", s && s.b_deg.act, "deg", "pos-b")}${pos("C", s && s.spindle_rpm, "rpm", "pos-c")}
      <div class="hint">${t("work offsets X {0} mm, Y {1} mm", fmt(s && s.x_offset_mm, 4), fmt(s && s.y_offset_mm, 4))}${s && s.moving_axis ? html` · <b data-testid="moving">${t("{0} moving", s.moving_axis)}</b>` : ""}</div>
    </div>
    <div class="card"><h2>${t("Continuous jog (hold the key)")}</h2>
      <div class="row">${t("speed")} <select value=${speed} onChange=${(e) => setSpeed(Number(e.target.value))} data-testid="jog-speed">
        ${[60, 300, 1000, 3000].map((v) => html`<option value=${v}>${t("{0} mm/min (deg/min B)", v)}</option>`)}</select></div>
      ${s && (!s.referenced.x || !s.referenced.y) ? html`<p class="warn">${t("Not referenced: X and Y jog at {0} mm/min at most, only the hardware limits protect.", unref)}</p>` : ""}
      <div class="jogpad">
        ${["x", "y", "b"].map((a) => html`<div class="row">
          <${HoldKey} conn=${conn} axis=${a} dir="-" speed=${speed} label=${`${a.toUpperCase()} −`} />
          <${HoldKey} conn=${conn} axis=${a} dir="+" speed=${speed} label=${`${a.toUpperCase()} +`} /></div>`)}
      </div></div>
    <div class="card"><h2>${t("Incremental jog")}</h2>
      <div class="row">${STEPS.map((v) => html`<button class=${`key small ${v === step ? "on" : ""}`} onClick=${() => setStep(v)}>${v}</button>`)}</div>
      ${["x", "y", "b"].map((a) => html`<div class="row">
        <${CmdButton} conn=${conn} op="jog" fields=${{ axis: a, distance: -step }} label=${`${a.toUpperCase()} −${step}`} testid=${`step-${a}-minus`} />
        <${CmdButton} conn=${conn} op="jog" fields=${{ axis: a, distance: step }} label=${`${a.toUpperCase()} +${step}`} testid=${`step-${a}-plus`} /></div>`)}
    </div>
    <${TouchOff} conn=${conn} />
    <div class="card"><h2>${t("Hob spindle C")}</h2>
      <p class="hint">${t("HOLD C turns the hob while your finger is on it (dead-man, as the jog keys). SPINDLE ON latches it until SPINDLE OFF or STOP.")}</p>
      <div class="row"><input inputmode="decimal" value=${rpm} data-testid="spindle-rpm" onInput=${(e) => setRpm(e.target.value)} /> rpm
        <${HoldKey} conn=${conn} axis="c" dir="+" speed=${rpm} label=${t("HOLD C")} />
        <b data-testid="spindle-actual">${s ? `${fmt(s.spindle_rpm, 1)} rpm` : "-"}</b></div>
      <div class="row"><${CmdButton} conn=${conn} op="spindle" fields=${{ rpm: String(rpm) }} label=${t("SPINDLE ON")} />
        <${CmdButton} conn=${conn} op="spindle" fields=${{ rpm: 0 }} label=${t("SPINDLE OFF")} /></div></div>
    <div class="card"><h2>${t("Align to cut gaps")}</h2>
      ${s && !s.referenced.table ? html`<p class="warn" data-testid="table-lost">${t("The table lost its position: CONTINUE would cut new gaps into this part. Align to its gaps (or NEW BLANK for a new part).")}</p>` : ""}
      <p class="hint">${t("For a part whose gaps are cut: spindle off, a hob tooth in a gap. Jog B − until a flank touches the tooth, tap FLANK AT B −; jog B + until the other flank touches, tap FLANK AT B +. The loop takes the middle as the part's tooth phase.")}</p>
      <div class="row"><${CmdButton} conn=${conn} op="touch_flank" fields=${{ turned: "-" }} label=${t("FLANK AT B −")} testid="touch-flank-minus" />
        <${CmdButton} conn=${conn} op="touch_flank" fields=${{ turned: "+" }} label=${t("FLANK AT B +")} testid="touch-flank-plus" /></div></div>
    <div class="card"><h2>${t("Set-up sheet")}${program ? `: ${program}` : ""}</h2>
      ${plan && s && s.program_loaded && conn.frame.loaded_here !== program ? html`<p class="warn" data-testid="setup-not-loaded">${t("The loop has another program loaded ({0}): this sheet is for {1}, load it before setting up.", conn.frame.loaded_here || "?", program)}</p>` : ""}
      ${plan ? html`<table class="kv" data-testid="setup-sheet">
        <tr><td>${t("hob swivel A (set by hand)")}</td><td><b>${fmt(plan.hob_swivel_deg, 3)}°</b> ${plan.hob_swivel_sense ? t(plan.hob_swivel_sense) : ""}</td></tr>
        <tr><td>${t("gearbox ratio (table rev per hob rev)")}</td><td>${fmt(plan.egb_ratio, 6)}</td></tr>
        <tr><td>${t("differential")}</td><td>${fmt(plan.differential_deg_per_mm, 6)} deg/mm</td></tr>
        ${Object.entries(plan.signs || {}).map(([k, v]) => html`<tr><td>${k.replaceAll("_", " ")}</td><td>${String(v)}</td></tr>`)}
      </table>` : html`<p class="hint">${t("Pick a program in PROGRAMS to see its set-up.")}</p>`}</div>
  </section>`;
}

// Touch-off: the work offsets as the loop has them, on the panel where they are set; the
// loop's answer stays beside the buttons (it names the old and the new offset and the
// change; no toast that vanishes). A touch-off the loop asks about (it does not fit the loaded blank, the previous
// offset or where the hob stands) opens a dialog with the loop's words: CONFIRM sends the
// same command confirmed, CANCEL leaves everything as it is. The page judges nothing: the
// gauge goes as typed (a decimal comma or point), the server reads it as the CLI does.
function TouchOff({ conn }) {
  const s = conn.frame && conn.frame.state;
  const [dia, setDia] = useState("");
  const [height, setHeight] = useState("");
  const [last, setLast] = useState(null);
  const answered = (axis, value) => (answer) => setLast({ axis, value, answer });
  const ask = last && !last.cancelled && !last.answer.ok && last.answer.refusal === "offset-needs-confirmation" ? last : null;
  const offset = (axis) => s && (axis === "x" ? s.x_offset_mm : s.y_offset_mm);
  const gauge = (axis, label, value, set) => html`<div class="row">${label} <input inputmode="decimal" value=${value} data-testid=${`touch-${axis}-value`} onInput=${(e) => set(e.target.value)} /> mm
    <${CmdButton} conn=${conn} op="touch_off" fields=${{ axis, value }} label=${t("TOUCH OFF {0}", axis.toUpperCase())} testid=${`touch-${axis}`} disabled=${value === ""} onAnswer=${answered(axis, value)} quiet /></div>`;
  return html`<div class="card"><h2>${t("Touch-off")}</h2>
    <div class="offsets" data-testid="touch-offsets"><span class="label">${t("work offsets now")}</span>
      <span class="off">X <b data-testid="touch-offset-x">${fmt(offset("x"), 4)}</b> mm</span> <span class="off">Y <b data-testid="touch-offset-y">${fmt(offset("y"), 4)}</b> mm</span></div>
    <p class="hint">${t("Bring the hob onto a gauge of known size, then enter it: the loop sets the work offset and saves it. It asks first when the offset would move more than the machine allows, or the gauge does not fit the loaded blank.")}</p>
    ${gauge("x", t("X: gauge diameter"), dia, setDia)}
    ${gauge("y", t("Y: gauge top above the table"), height, setHeight)}
    ${last && !ask ? html`<p class=${`answer ${last.answer.ok ? "ok" : "bad"}`} data-testid="touch-answer">${last.cancelled ? `${t("CANCELLED, nothing changed:")} ` : last.answer.ok ? "" : `${t("REFUSED:")} `}${last.answer.text}</p>` : ""}
    ${ask ? html`<div class="modal-back"><div class="modal" role="dialog" aria-modal="true" data-testid="touch-confirm">
        <h2>${t("Touch-off {0}: the loop asks before it sets this offset", ask.axis.toUpperCase())}</h2>
        <div class="offsets">${t("work offset {0} now", ask.axis.toUpperCase())} <b>${fmt(offset(ask.axis), 4)}</b> mm, ${t("gauge {0} mm", ask.value)}</div>
        <p class="loop-text" data-testid="touch-confirm-text">${ask.answer.text}</p>
        <p class="hint">${t("Check the gauge's value and where the hob stands. CONFIRM sets the offset named above; CANCEL changes nothing.")}</p>
        <div class="row">
          <button class="key" data-testid="touch-cancel" onClick=${() => setLast({ ...ask, cancelled: true })}>${t("CANCEL")}</button>
          <${CmdButton} conn=${conn} op="touch_off" fields=${{ axis: ask.axis, value: ask.value, confirm: true }} label=${t("CONFIRM {0} OFFSET", ask.axis.toUpperCase())} cls="warnkey" testid="touch-confirm-yes" onAnswer=${answered(ask.axis, ask.value)} quiet /></div>
      </div></div>` : ""}
  </div>`;
}

// The span form's fields: the key the server names a problem by, and the operator's words.
const SPAN_FIELDS = [
  ["k", "span.k", () => t("teeth spanned k"), ""],
  ["measured_mm", "span.measured_mm", () => t("measured span W"), "mm"],
  ["drawing_mm", "span.drawing_mm", () => t("drawing's span (empty: nominal)"), "mm"],
  ["upper_mm", "span.upper_mm", () => t("upper allowance (e.g. -0,050)"), "mm"],
  ["lower_mm", "span.lower_mm", () => t("lower allowance (e.g. -0,090)"), "mm"],
  ["profile_shift", "span.profile_shift", () => t("profile shift x (empty: 0)"), ""],
];
const spanLabel = (key) => (key === "span.after" ? t("measured after") : (SPAN_FIELDS.find((f) => f[1] === key) || [0, 0, () => key])[2]());
const VERDICT = { good: () => t("GOOD: within the drawing's allowances"), over: () => t("OVER: depth still to cut") };

export function Single({ conn, program }) {
  const s = conn.frame && conn.frame.state;
  // Each field as typed (a decimal comma or point): the server reads and checks them.
  const [v, setV] = useState({ after: "single" });
  const [res, setRes] = useState(null);
  const body = () => ({ program, ...Object.fromEntries(SPAN_FIELDS.map(([name]) => [name, v[name] || ""])), after: v.after });
  const compute = async () => setRes(await api("POST", "/api/span", body()));
  const carry = async () => setRes({ ...res, carried: await api("POST", `/api/span/carry`, body()) });
  const problemOf = (key) => res && !res.ok && (res.problems || []).find((p) => p.key === key);
  return html`<section class="grid2">
    <div class="card"><h2>${t("Single pass")}${program ? `: ${program}` : ""}</h2>
      <p class="hint">${t("One pass at the program's single depth, then measure the span and carry the depth left into the automatic program.")}</p>
      <div class="row">
        <${CmdButton} conn=${conn} op="load" fields=${{ program: program || "" }} label=${t("LOAD")} disabled=${!program} />
        <${CmdButton} conn=${conn} op="start" fields=${{ single: true }} label=${t("START SINGLE")} cls="primary" testid="start-single" />
        <${CmdButton} conn=${conn} op="stop" label=${t("STOP")} cls="stop" /></div>
      <${PitchComp} conn=${conn} />
      <div class="pos"><span class="label">${t("state")}</span><b>${s ? t(s.state_words) : "-"}</b></div></div>
    <div class="card"><h2>${t("Span measurement")}</h2>
      <div class="row">${t("measured after")}
        ${["single", "whole"].map((a) => html`<button class=${`key small ${v.after === a ? "on" : ""}`} data-testid=${`span-after-${a}`} onClick=${() => setV({ ...v, after: a })}>${a === "single" ? t("THE SINGLE PASS") : t("THE WHOLE CUT")}</button>`)}</div>
      ${SPAN_FIELDS.map(([name, key, label, unit]) => html`<div class=${`field ${problemOf(key) ? "problem" : ""}`}><span>${label()}</span>
        <input inputmode="decimal" data-key=${key} value=${v[name] || ""} onInput=${(e) => setV({ ...v, [name]: e.target.value })} /><span>${unit}</span>
        ${problemOf(key) ? html`<em class="why">${problemOf(key).message}</em>` : ""}</div>`)}
      <div class="row"><button class="key" onClick=${compute} disabled=${!program} data-testid="span-compute">${t("COMPUTE")}</button>
        <button class="key primary" onClick=${carry} disabled=${!res || !res.ok || !(res.inputs && res.inputs.depth_to_cut_mm > 0) || !allows(conn, "compensate")} data-testid="span-carry">${t("CARRY INTO PROGRAM")}</button>
        ${allows(conn, "compensate") ? "" : html`<span class="hint" data-testid="carry-level">${t("CARRY: a setter's work")}</span>`}</div>
      ${res && !res.ok ? html`<p class="bad" data-testid="span-refused">${res.refused} ${(res.problems || []).map((p) => html`<br />${spanLabel(p.key)}: ${p.message}`)}</p>` : ""}
      ${res && res.ok ? html`<p class=${res.inputs.verdict === "good" ? "ok" : "warn"} data-testid="span-verdict"><b>${VERDICT[res.inputs.verdict]()}</b>: ${t("W {0} mm, allowed {1} .. {2} mm", fmt(res.inputs.measured_span_mm, 4), fmt(res.inputs.span_min_mm, 4), fmt(res.inputs.span_max_mm, 4))}${res.inputs.depth_to_cut_mm > 0 ? `, ${t("{0} mm to cut to the middle", fmt(res.inputs.depth_to_cut_mm, 3))}` : ""}</p>
        <table class="kv" data-testid="span-result">${Object.entries(res.inputs || {}).filter(([k2]) => k2 !== "verdict").map(([k2, val]) => html`<tr><td>${k2.replaceAll("_", " ").replace(/ mm$/, " (mm)").replace(/ deg$/, " (deg)")}</td><td>${typeof val === "number" && !Number.isInteger(val) ? fmt(val, 4) : val}</td></tr>`)}</table>
        <p class="hint">${t("depth to cut = (measured span − middle of the drawing's band) / (2 sin αn), none inside the band's lower half; new total depth = the depth cut + depth to cut")}</p>` : ""}
      ${res && res.carried ? html`<p class=${res.carried.ok ? "ok" : "bad"}>${res.carried.ok ? t("saved: total depth {0} mm", fmt(res.carried.total_depth_mm, 3)) : res.carried.refused}</p>` : ""}
    </div></section>`;
}

// The pitch compensation hob-rt loaded for the machine's worm set (`hob compensate`), as the
// loop's state has it, beside the keys that start a cut: a cut with it on is not the cut
// with it off. Its key says what it does: ON when off, OFF when on. With none loaded the key
// is shown unavailable, with the reason, and still sends: the loop decides (it refuses it in
// a cycle, with the gearbox coupled, or ON without one) and its answer shows as every other.
const PITCH_COMP_STATE = { none: () => t("NONE"), off: () => t("OFF"), on: () => t("ON") };

function PitchComp({ conn }) {
  const s = conn.frame && conn.frame.state;
  const pc = s ? s.pitch_compensation : "";
  const worm = conn.hello && conn.hello.worm_set;
  const on = pc === "on";
  const why = pc !== "none" ? "" : worm ? t("no compensation stored for this worm set: run hob compensate") : t("the machine file names no worm set (table.worm_set): none is loaded");
  return html`<div class="row pitch-comp" data-testid="pitch-comp" data-state=${pc}>
    <span class="pc-state"><span class="label">${t("pitch comp")}:</span> <b class=${on ? "ok" : pc === "none" ? "warn" : ""} data-testid="pitch-comp-state">${PITCH_COMP_STATE[pc] ? PITCH_COMP_STATE[pc]() : pc || "-"}</b></span>
    <${CmdButton} conn=${conn} op="pitch_compensation" fields=${{ on: !on }} label=${on ? t("PITCH COMP OFF") : t("PITCH COMP ON")} cls=${`small ${why ? "unavailable" : ""}`} testid="pitch-comp-key" disabled=${!s} />
    ${why ? html`<span class="hint" data-testid="pitch-comp-why">${why}</span>` : worm ? html`<span class="hint">${t("worm set {0}", worm)}</span>` : ""}</div>`;
}

export function Automatic({ conn, program }) {
  const s = conn.frame && conn.frame.state;
  const ranges = conn.hello ? conn.hello.overrides : { feed: [0, 120], spindle: [50, 120] };
  const v = conn.frame && conn.frame.speeds;
  // The feed override's steps: from the loop's own value, within the machine's range; the
  // value shown is always the loop's (a slider showed its own, not what the loop took).
  const feedNow = s ? s.feed_override_percent : null;
  const feedStep = (d) => Math.max(ranges.feed[0], Math.min(ranges.feed[1], Math.round(((feedNow ?? 100) + d) / 5) * 5));
  const progress = s && s.passes ? (100 * Math.max(0, s.pass - 1)) / s.passes : 0;
  return html`<section class="grid2">
    <div class="card wide"><h2>${t("Automatic")}${program ? `: ${program}` : ""}</h2>
      <div class="row">
        <${CmdButton} conn=${conn} op="load" fields=${{ program: program || "" }} label=${t("LOAD")} disabled=${!program} />
        <${CmdButton} conn=${conn} op="start" fields=${{ single: false }} label=${t("CYCLE START")} cls="primary" testid="start-auto" />
        <${CmdButton} conn=${conn} op="hold" label=${t("FEED HOLD")} testid="feed-hold" />
        <${CmdButton} conn=${conn} op="resume" label=${t("RESUME")} testid="resume" />
        <${CmdButton} conn=${conn} op="stop" label=${t("STOP")} cls="stop" />
        <${CmdButton} conn=${conn} op="continue" label=${s && s.continue_pass ? (s.continue_from_y_mm != null ? t("CONTINUE FROM PASS {0} AT Y {1}", s.continue_pass, s.continue_from_y_mm.toFixed(1)) : t("CONTINUE FROM PASS {0}", s.continue_pass)) : t("CONTINUE")} disabled=${!(s && s.continue_pass)} />
        <${CmdButton} conn=${conn} op="new_blank" label=${t("NEW BLANK")} /></div>
      <${PitchComp} conn=${conn} />
      <div class="progress"><div style=${`width:${progress}%`}></div></div>
      <div class="row"><span class="label">${t("state")}</span><b data-testid="auto-state">${s ? t(s.state_words) : "-"}</b>
        <span class="label">${t("pass")}</span><b>${s ? t("{0} of {1}", s.pass, s.passes) : "-"}</b>
        <span class="label">${t("time left")}</span><b data-testid="time-left">${conn.frame && conn.frame.time_left_s !== null && conn.frame.time_left_s !== undefined ? mmss(conn.frame.time_left_s) : s && s.pass ? t("unknown (the program was not loaded here)") : "-"}</b>
        <span class="label">${t("sync error")}</span><b>${s ? fmt(s.sync_error_arcsec, 2) : "-"}"</b>
        <span class="label">${t("bound")}</span><b>${s && s.bound_arcsec ? `±${fmt(s.bound_arcsec, 1)}"` : "-"}</b></div>
      <div class="axes" data-testid="auto-axes">
        ${[["X", s && s.x_mm.act, 3, "mm", "auto-x"], ["Y", s && s.y_mm.act, 3, "mm", "auto-y"], ["B", s && s.b_deg.act, 3, "°", "auto-b"],
           [t("hob"), s && s.spindle_rpm, 1, t("rpm (set {0})", s ? fmt(s.spindle_set_rpm, 0) : "-"), "auto-rpm"],
           [t("table"), v && v.table_rpm, 3, t("rpm"), "auto-table-rpm"], [t("feed Y"), v && v.y_feed_mm_min, 1, "mm/min", "auto-feed"]]
          .map(([label, x, d, unit, id]) => html`<div class="ax"><span class="label">${label}</span><b data-testid=${id}>${s && x !== null && x !== undefined ? fmt(x, d) : "-"}</b> <small>${unit}</small></div>`)}</div>
      <${SyncPlot} points=${conn.plot} bound=${s && s.bound_arcsec} version=${conn.frame && conn.frame.seq} periodUs=${conn.stats && conn.stats.period_us} /></div>
    <div class="card"><h2>${t("Feed override")} <b data-testid="feed-now">${feedNow === null ? "-" : `${fmt(feedNow, 0)} %`}</b></h2>
      <div class="row">${[50, 80, 100, 120].filter((p) => p >= ranges.feed[0] && p <= ranges.feed[1]).map((p) => html`
        <${CmdButton} conn=${conn} op="override" fields=${{ what: "feed", percent: p }} label=${`${p} %`} testid=${`feed-${p}`} />`)}</div>
      <div class="row">${[-10, -5, 5, 10].map((d) => html`
        <${CmdButton} conn=${conn} op="override" fields=${{ what: "feed", percent: feedStep(d) }} label=${`${d > 0 ? "+" : "−"}${Math.abs(d)} %`} testid=${`feed-step${d > 0 ? "+" : "-"}${Math.abs(d)}`} disabled=${feedNow === null} />`)}</div></div>
    <div class="card"><h2>${t("Spindle override")}</h2>
      <div class="row">${[80, 100, 110, 120].filter((p) => p >= ranges.spindle[0] && p <= ranges.spindle[1]).map((p) => html`
        <${CmdButton} conn=${conn} op="override" fields=${{ what: "spindle", percent: p }} label=${`${p} %`} testid=${`spindle-${p}`} />`)}</div>
      <p class="hint">${t("In the cut the spindle speed ramps to the new value (10 rpm/s) so the table keeps up.")}</p></div>
  </section>`;
}

// The gear each pass left, as ISO 1328-1 would measure it, from the simulated machine's
// truth (the server's report; `hob log report` prints the same): the gear's deviations and
// the controller's share of them.
function PredictedGear(tr, samples) {
  const dev = (g, um, tol) => (g ? html`${fmt(g[um], 2)} um <span class="small">(${fmt((100 * g[um]) / g[tol], 0)} %)</span>` : "-");
  return html`<h3 data-testid="report-truth">${t("Graded by the simulated machine's truth ({0} of {1} samples): predicted gear", tr.joined, samples)}</h3>
    <table class="grid"><tr><th>${t("pass")}</th><th>${t("true max um")}</th><th>${t("grade")}</th><th>f<sub>pt</sub></th><th>F<sub>p</sub></th><th>${t("helix")}</th><th>${t("controller's")} f<sub>pt</sub></th><th>${t("controller's")} F<sub>p</sub></th></tr>
      ${tr.passes.map((p) => html`<tr data-testid="report-predicted"><td>${p.pass}</td><td>${fmt(p.sync_err_max_um, 3)}</td><td>${p.predicted ? p.predicted.grade : "-"}</td>
        <td>${dev(p.predicted, "single_pitch_um", "single_pitch_tolerance_um")}</td><td>${dev(p.predicted, "cumulative_pitch_um", "cumulative_pitch_tolerance_um")}</td><td>${dev(p.predicted, "helix_um", "helix_tolerance_um")}</td>
        <td>${dev(p.controller_share, "single_pitch_um", "single_pitch_tolerance_um")}</td><td>${dev(p.controller_share, "cumulative_pitch_um", "cumulative_pitch_tolerance_um")}</td></tr>`)}</table>`;
}

export function Report() {
  const [r, setR] = useState(null);
  const load = () => api("GET", "/api/cut/report").then(setR);
  useEffect(() => { load(); }, []);
  if (!r) return html`<p>${t("reading the logger's record...")}</p>`;
  if (!r.ok) return html`<section class="card"><h2>${t("Cut report")}</h2><p class="bad">${r.refused}</p><button class="key" onClick=${load}>${t("READ AGAIN")}</button></section>`;
  const tol = r.grade5_single_pitch_um;
  return html`<section class="card report" data-testid="report"><h2>${t("Cut report")}</h2>
    <p data-testid="report-what"><b>${r.what}</b></p>
    <div data-testid="report-header">${r.header_lines.map((l) => html`<p class=${l.startsWith("  ") ? "small report-alarm" : ""}>${l}</p>`)}</div>
    <p>${t("{0} samples recorded, {1} missing (cycles {2}..{3}); pitch radius {4} mm; ISO 1328-1 single pitch tolerance, grade 5: {5} µm; bound (a quarter): {6} µm.", r.samples, r.missing, r.first_cycle, r.last_cycle, fmt(r.pitch_radius_mm, 3), fmt(tol, 2), fmt(r.bound_um, 2))}</p>
    <p class="small">${t("Synchronisation error in the cut as the controller estimates it from its encoders:")}</p>
    <table class="grid"><tr><th>${t("pass")}</th><th>${t("cut s")}</th><th>${t("pass s")}</th><th>${t("stood s")}</th><th>${t("samples")}</th><th>${t("RMS \"")}</th><th>${t("max \"")}</th><th>${t("RMS um")}</th><th>${t("max um")}</th><th>${t("max / tolerance")}</th><th>${t("feed override %")}</th><th>${t("spindle override %")}</th><th>${t("pitch compensation")}</th></tr>
      ${r.passes.map((p) => html`<tr data-testid="report-pass"><td>${p.pass}</td><td>${fmt(p.cut_time_s, 1)}</td><td>${fmt(p.pass_time_s, 1)}</td><td>${fmt(p.stood_s, 1)}</td><td>${p.samples}</td><td>${fmt(p.sync_err_rms_arcsec, 2)}</td><td>${fmt(p.sync_err_max_arcsec, 2)}</td>
        <td>${fmt(p.sync_err_rms_um, 3)}</td><td>${fmt(p.sync_err_max_um, 3)}</td><td class=${p.sync_err_max_um > r.bound_um ? "bad" : "ok"}>${fmt((100 * p.sync_err_max_um) / tol, 1)} %</td>
        <td>${p.feed_override_min_percent == null ? "-" : `${fmt(p.feed_override_min_percent, 0)}..${fmt(p.feed_override_max_percent, 0)}`}</td>
        <td>${p.spindle_override_min_percent == null ? "-" : `${fmt(p.spindle_override_min_percent, 0)}..${fmt(p.spindle_override_max_percent, 0)}`}</td>
        <td data-testid="report-pitch-compensation">${PITCH_COMP_STATE[p.pitch_compensation] ? PITCH_COMP_STATE[p.pitch_compensation]() : "-"}</td></tr>`)}</table>
    <p class="small" data-testid="report-durations">${t("Durations:")} ${r.durations}.</p>
    ${r.truth ? PredictedGear(r.truth, r.samples) : html`<p class="small" data-testid="report-no-truth">${t("The error above is the controller's own estimate from its encoders ({0}).", r.truth_refused ? t("no truth used: {0}", r.truth_refused) : t("no truth of a simulated machine beside the record"))}</p>`}
    <div class="row noprint"><button class="key" onClick=${load}>${t("READ AGAIN")}</button><button class="key" onClick=${() => window.print()}>${t("PRINT")}</button></div></section>`;
}

const time = (e) => (e.utc_ms ? new Date(e.utc_ms).toLocaleTimeString("en-GB", { hour12: false }) : `cycle ${e.cycle}`);

// The event log's filters: by kind, severity and axis (each event's class comes from the
// server, `codec::event_class`). Repeated bus noise is one line with its count.
const EVENT_FILTERS = [
  ["group", () => t("kind"), [["", () => t("ALL")], ["alarm", () => t("ALARMS")], ["operator", () => t("OPERATOR")], ["bus", () => t("BUS")], ["cycle", () => t("CYCLE")]]],
  ["severity", () => t("severity"), [["", () => t("ANY")], ["alarm", () => t("ALARM")], ["warning", () => t("WARNING")]]],
  ["axis", () => t("axis"), [["", () => t("ANY")], ["X", () => "X"], ["Y", () => "Y"], ["B", () => "B"]]],
];

export function Alarms({ conn }) {
  const [filter, setFilter] = useState({ group: "", severity: "", axis: "" });
  const only = Object.values(filter).join("/");
  // Pages older than the live events: the server's ring, then the logger's record.
  const [older, setOlder] = useState({ list: [], done: false, note: "" });
  const live = [...conn.events].reverse();
  const oldest = [...live, ...older.list].reduce((m, e) => Math.min(m, e.seq), Infinity);
  const [loading, setLoading] = useState(false);
  const more = () => { setLoading(true); return api("GET", `/api/alarms/page?before=${Number.isFinite(oldest) ? oldest : 0}`).then((r) => {
    setLoading(false);
    if (!r.ok) { setOlder({ ...older, note: r.refused || `HTTP ${r.status}` }); return; }
    const seen = new Set([...live, ...older.list].map((e) => e.seq));
    const fresh = r.events.filter((e) => !seen.has(e.seq));
    setOlder({ list: [...older.list, ...fresh], done: fresh.length === 0, note: r.from_log ? t("{0} from the logger's record", r.from_log) : "" });
  }); };
  const severe = { alarm: 2, warning: 1, info: 0 };
  const list = [...live, ...older.list].filter((e) => (!filter.group || e.group === filter.group)
    && (!filter.severity || (severe[e.severity] ?? 0) >= severe[filter.severity])
    && (!filter.axis || e.axis === filter.axis));
  return html`<section class="card"><h2>${t("Alarms and events")}</h2>
    ${EVENT_FILTERS.map(([key, label, options]) => html`<div class="row"><span class="label">${label()}</span>${options.map(([value, text]) => html`
      <button class=${`key small ${filter[key] === value ? "on" : ""}`} data-testid=${`filter-${key}-${value || "all"}`} onClick=${() => setFilter({ ...filter, [key]: value })}>${text()}</button>`)}</div>`)}
    <div class="row"><button class="key small" data-testid="older-events" data-loading=${loading ? "yes" : "no"} disabled=${older.done || loading} onClick=${more}>${older.done ? t("NO OLDER EVENTS") : t("OLDER")}</button>
      ${older.note ? html`<span class="small" data-testid="older-note">${older.note}</span>` : ""}
      ${conn.lost.length ? html`<span class="warn">${t("events {0} are older than the HMI's memory: {1}", conn.lost.map((l) => `${l.from}..${l.to}`).join(", "), conn.lost[0].why)}</span>` : ""}</div>
    <${EventRows} rows=${foldBus(list)} version=${`${only}:${list.length}:${list.length ? list[0].seq : ""}:${list.length ? list[list.length - 1].seq : ""}`} /></section>`;
}

// Consecutive bus events with the same words (a drive's TPDO late, over and over) as one
// row with their count, newest first.
function foldBus(list) {
  const rows = [];
  for (const e of list) {
    const last = rows[rows.length - 1];
    if (last && e.group === "bus" && last.e.group === "bus" && last.e.text === e.text) { last.count++; last.first = e.seq; }
    else rows.push({ e, count: 1, first: e.seq });
  }
  return rows;
}

// The table of events is re-drawn when its events change, not with every frame of the loop:
// a burst of bus events (thousands of rows) must not slow the page's other screens or taps.
class EventRows extends Component {
  shouldComponentUpdate(next) {
    return next.version !== this.props.version;
  }

  render({ rows }) {
    return html`<table class="grid events"><tr><th>#</th><th>${t("time")}</th><th>${t("who")}</th><th>${t("what")}</th></tr>
      ${rows.map(({ e, count, first }) => html`<tr class=${e.kind} data-testid="event" data-severity=${e.severity} data-axis=${e.axis || ""}><td>${count > 1 ? `${first}..${e.seq}` : e.seq}</td><td>${time(e)}</td><td>${e.operator ? t("operator") : t("machine")}</td>
        <td>${e.text}${count > 1 ? html` <b class="warn" data-testid="folded">×${count}</b>` : ""}${e.alarm ? html`<div class="small"><b>${t("the machine")}:</b> ${e.alarm.reaction}<br /><b>${t("remedy")}:</b> ${e.alarm.remedy}<br /><b>${t("to continue")}:</b> ${e.alarm.how_to_continue}</div>` : ""}</td></tr>`)}</table>`;
  }
}

// A whole distribution as bars in powers of two; the bar's length is log10 of its count, so
// that a tail of one cycle in a million is still seen.
function Bars({ title, bars, testid }) {
  if (!bars || !bars.length) return "";
  const top = Math.log10(Math.max(...bars.map((b) => b.count)) + 1);
  const us = (v) => (v >= 1000 ? `${fmt(v / 1000, 1)} ms` : `${fmt(v, v < 10 ? 1 : 0)} us`);
  return html`<div class="bars" data-testid=${testid}><h3>${title} ${t("(cycles, log scale)")}</h3>
    ${bars.map((b) => html`<div class="bar"><span class="range">${us(b.lo_us)}–${us(b.hi_us)}</span>
      <span class="fill" style=${`width:${top > 0 ? (70 * Math.log10(b.count + 1)) / top : 0}%`}></span><span class="n">${b.count}</span></div>`)}</div>`;
}

/** Commissioning: four procedures of the server's hob_commission (those of `hob commission
 *  delay`, `hob commission encoder`, `hob commission backlash` and `hob commission
 *  response`), each run while its key
 *  is held (the held key its enable: letting go stops the table or the spindle); one at a
 *  time (the server refuses another key's press while one runs, and says so); the proposal
 *  of the one that ran last, its fit and its diff; WRITE at the builder's level. */
function CommissionKey({ conn, procedure, testid }) {
  const ref = useRef(null);
  useEffect(() => {
    const el = ref.current;
    let timer = null;
    const stop = () => {
      if (!timer) return;
      clearInterval(timer); timer = null;
      el.classList.remove("held");
      conn.send({ t: "commission_release" });
    };
    const down = (ev) => {
      ev.preventDefault();
      stop();
      try { el.setPointerCapture(ev.pointerId); } catch { /* a synthetic pointer */ }
      conn.send({ t: "commission_hold", id: conn.newId(), procedure });
      el.classList.add("held");
      timer = setInterval(() => conn.send({ t: "commission_renew" }), RENEW_MS);
    };
    el.addEventListener("pointerdown", down);
    for (const k of ["pointerup", "pointercancel", "lostpointercapture"]) el.addEventListener(k, stop);
    el.addEventListener("contextmenu", (e) => e.preventDefault());
    window.addEventListener("blur", stop);
    return () => {
      stop();
      el.removeEventListener("pointerdown", down);
      for (const k of ["pointerup", "pointercancel", "lostpointercapture"]) el.removeEventListener(k, stop);
      window.removeEventListener("blur", stop);
    };
  }, [conn, procedure]);
  return html`<button ref=${ref} class="key hold" data-testid=${testid} data-procedure=${procedure} disabled=${!allows(conn, "command")}>${t("HOLD TO MEASURE")}</button>`;
}

/** A procedure's last word: its step while it runs, its result, or why it stopped. */
function CommissionState({ view, testid }) {
  if (!view) return html`<p class="hint" data-testid=${testid} data-state="">${t("not run since the page opened")}</p>`;
  const bad = view.state === "stopped" || view.state === "refused";
  return html`<p class=${bad ? "warn" : view.state === "running" ? "ok" : ""} data-testid=${testid} data-state=${view.state}>${view.text}</p>`;
}

const PROCEDURES = { delay: "TABLE DRIVE DELAY", encoder: "SPINDLE ENCODER", backlash: "TABLE BACKLASH", response: "TABLE RESPONSE" };

/** The proposal's fit in words and its diff; the response's with its Bode plot beside the
 *  fit (the server's SVG, made by hob_commission's `response::bode::svg` from numbers). */
function Proposal({ p }) {
  const report = html`<pre class="small" style=${p.procedure === "encoder" ? "" : "white-space: pre-wrap"} data-testid="commission-report">${p.report}</pre>`;
  return html`${p.bode ? html`<div class="bode-result"><div class="bode" data-testid="commission-bode" dangerouslySetInnerHTML=${{ __html: p.bode }}></div>${report}</div>` : report}
    <pre class="small" data-testid="commission-diff">${p.diff}</pre>`;
}

function Commissioning({ conn }) {
  const c = conn.commission;
  const by = conn.commissionBy || {};
  const p = c && c.proposal;
  const e = conn.hello && conn.hello.commissioning && conn.hello.commissioning.encoder;
  const b = conn.hello && conn.hello.commissioning && conn.hello.commissioning.backlash;
  const r = conn.hello && conn.hello.commissioning && conn.hello.commissioning.response;
  const write = () => conn.send({ t: "commission_write", id: conn.newId() });
  return html`<div class="card wide" data-testid="commissioning"><h2>${t("Commissioning")}</h2>
    ${c && !PROCEDURES[c.procedure] ? html`<p class="warn" data-testid="commission-other" data-state=${c.state}>${c.text}</p>` : ""}
    <div class="procedures">
      <div class="procedure" data-testid="commission-delay"><h3>${t("TABLE DRIVE DELAY")}</h3>
        <p class="hint">${t("The table turns + at 240 deg/min for 3 s, then - as long (12 deg each way, back to where it stands): keep the table clear and hold the key until the result shows; letting go stops the table. The found delay is written into the machine file only by WRITE (a builder's work); restart hob-rt after it.")}</p>
        <div class="row"><${CommissionKey} conn=${conn} procedure="delay" testid="commission-hold" /></div>
        <${CommissionState} view=${by.delay} testid="commission-state" /></div>
      <div class="procedure" data-testid="commission-encoder"><h3>${t("SPINDLE ENCODER")}</h3>
        <p class="warn" data-testid="commission-encoder-warning">${e ? t("The hob spindle turns at up to {0} rpm for about {1} min while the key is held: the hob must be clear of the work.", fmt(e.max_rpm, 0), fmt(e.about_min, 0))
          : t("The hob spindle turns at up to the machine's largest speed for some minutes while the key is held: the hob must be clear of the work.")}</p>
        <p class="hint">${e ? t("{0} speeds in turn ({1} rpm), each read {2} s once steady; letting go stops the spindle. The encoder's error is written into the machine file only by WRITE (a builder's work); restart hob-rt after it.", e.speeds_rpm.length, e.speeds_rpm.map((r) => fmt(r, 0)).join(", "), fmt(e.seconds, 0)) : ""}</p>
        <div class="row"><${CommissionKey} conn=${conn} procedure="encoder" testid="commission-encoder-hold" /></div>
        <${CommissionState} view=${by.encoder} testid="commission-encoder-state" /></div>
      <div class="procedure" data-testid="commission-backlash"><h3>${t("TABLE BACKLASH")}</h3>
        ${b && b.gauge_channel === null ? html`<p class="warn" data-testid="commission-backlash-gauge">${t("The machine file names no table gauge (io.analog_inputs.table_gauge): the measurement is refused until a gauge on the table's rim is wired to an analog input and named.")}</p>`
          : b ? html`<p class="hint" data-testid="commission-backlash-gauge">${t("The gauge on the table's rim, on the coupler's analog input {0}, reads the table; the motor is compared with it.", b.gauge_channel)}</p>` : ""}
        <p class="hint">${b ? t("The table turns + at {0} deg/min for {1} s, then - and + again as long ({2} deg each way, about {3} s in all): keep the table clear and hold the key until the result shows; letting go stops the table. The lost motion is written into the machine file only by WRITE (a builder's work), for the commissioning report; the loop does not use it.", fmt(b.speed_deg_min, 1), fmt(b.seconds, 0), fmt(b.travel_deg, 3), fmt(b.about_s, 0)) : ""}</p>
        <div class="row"><${CommissionKey} conn=${conn} procedure="backlash" testid="commission-backlash-hold" /></div>
        <${CommissionState} view=${by.backlash} testid="commission-backlash-state" /></div>
      <div class="procedure" data-testid="commission-response"><h3>${t("TABLE RESPONSE")}</h3>
        ${r && !r.drive_model ? html`<p class="warn" data-testid="commission-response-model">${t("The machine file has no [table.drive_model] (the motor side's inertia, the drive's loop period and speed filter from their data sheets): the measurement is refused until it has.")}</p>` : ""}
        <p class="hint">${r ? t("The table's target swings by about an arcsec at {0} frequencies from {1} to {2} Hz, then as many again about the deepest dip, the table creeping + at {5} deg/min meanwhile (about {3} s, {4} deg of the table): keep the table clear and unclamped and hold the key until the Bode plot shows; letting go stops the swing. The proposed drive gains are written into the machine file only by WRITE (a builder's work); hob-rt's boot writes them to the drive.", r.points, fmt(r.from_hz, 0), fmt(r.to_hz, 0), fmt(r.about_s, 0), fmt(r.creep_deg, 0), fmt(r.creep_deg_min, 0)) : ""}</p>
        <div class="row"><${CommissionKey} conn=${conn} procedure="response" testid="commission-response-hold" /></div>
        <${CommissionState} view=${by.response} testid="commission-response-state" /></div>
    </div>
    <div class="row"><button class="key primary" onClick=${write} disabled=${!p || !allows(conn, "edit_machine_data")} data-testid="commission-write">${t("WRITE")}</button>
      ${p ? html`<span data-testid="commission-proposal-of" data-procedure=${p.procedure}>${t("the proposal of {0}", t(PROCEDURES[p.procedure] || p.procedure))}</span>` : html`<span class="hint">${t("nothing measured to write")}</span>`}
      ${allows(conn, "edit_machine_data") ? "" : html`<span class="hint" data-testid="commission-level">${t("WRITE: a builder's work")}</span>`}</div>
    ${p ? html`<${Proposal} p=${p} />` : ""}
  </div>`;
}

export function Diagnostics({ conn }) {
  const s = conn.frame && conn.frame.state, st = conn.stats;
  const pct = (p) => (p ? html`<td>${fmt(p.min, 1)}</td><td>${fmt(p.p50, 1)}</td><td>${fmt(p.p99, 1)}</td><td>${fmt(p.p999, 1)}</td><td>${fmt(p.max, 1)}</td><td>${p.count}</td>` : "");
  // Repeated bus noise folded: one line per kind and node, its count and its latest time.
  const folded = new Map();
  for (const e of conn.events.filter((e) => e.kind === "bus")) {
    const key = e.text.replace(/ in \d+ cycles?.*$/, "");
    const f = folded.get(key);
    folded.set(key, { e, count: f ? f.count + 1 : 1 });
  }
  const bus = [...folded.values()].sort((a, b) => b.e.seq - a.e.seq).slice(0, 20);
  return html`<section class="grid2">
    <div class="card"><h2>${t("The loop")}</h2>${st ? html`
      <table class="grid"><tr><th>us</th><th>${t("min")}</th><th>p50</th><th>p99</th><th>p99.9</th><th>${t("max")}</th><th>${t("cycles")}</th></tr>
        <tr><td>${t("wake-up")}</td>${pct(st.wake_us)}</tr><tr><td>${t("compute")}</td>${pct(st.compute_us)}</tr></table>
      <${Bars} title=${t("wake-up latency")} bars=${st.wake_bars} testid="wake-histogram" />
      <${Bars} title=${t("compute time")} bars=${st.compute_bars} testid="compute-histogram" />
      <table class="kv"><tr><td>${t("period")}</td><td>${fmt(st.period_us, 0)} us</td></tr><tr><td>${t("overruns")}</td><td data-testid="overruns">${st.overruns}</td></tr>
        <tr><td>${t("heap allocations in cycles")}</td><td data-testid="allocations">${st.system_allocations_in_cycle} (pool ${st.pool_allocations_in_cycle})</td></tr>
        <tr><td>${t("scheduling")}</td><td>${st.fifo_priority > 0 ? `SCHED_FIFO ${st.fifo_priority}` : t("NOT SCHED_FIFO")}, ${st.core >= 0 ? t("core {0}", st.core) : t("not pinned")}, ${st.memory_locked ? t("memory locked") : t("memory NOT locked")}</td></tr>
        <tr><td>${t("bus")}</td><td>${st.bus}, ${t("{0} frames not sent", st.tx_errors)}</td></tr>
        <tr><td>${t("samples the HMI missed")}</td><td>${conn.frame ? conn.frame.samples_missed : "-"}</td></tr>
        <tr><td>${t("recorder")}</td><td class=${conn.frame && conn.frame.recorder.alarm ? "warn" : ""} data-testid="recorder">${conn.frame ? conn.frame.recorder.text : "-"}</td></tr></table>` : html`<p>${t("no stats from the loop yet")}</p>`}</div>
    <div class="card"><h2>${t("Drives and CAN nodes")}</h2>
      <table class="grid" data-testid="nodes"><tr><th>${t("node")}</th><th>${t("NMT")}</th><th>${t("heartbeat")}</th><th>${t("CiA 402 (statusword)")}</th><th>${t("last EMCY")}</th><th>${t("feedback")}</th></tr>
        ${s ? s.nodes.map((n) => html`<tr data-node=${n.name}><td>${n.name === "I/O" ? t("I/O coupler") : t("drive {0}", n.name)}</td>
          <td class=${n.nmt === "operational" ? "" : "warn"}>${t(n.nmt)}</td><td>${n.nmt === "not heard" ? "-" : t("{0} ms ago", fmt(n.heartbeat_age_ms, 0))}</td>
          <td class=${n.cia402 && n.cia402.includes("fault") ? "warn" : ""}>${n.cia402 ? t(n.cia402) : "-"}${n.statusword ? html`<div class="small">${n.statusword}</div>` : ""}</td>
          <td class=${n.emcy ? "warn" : ""} data-testid=${`emcy-${n.name}`}>${n.emcy || "-"}</td>
          <td>${n.name === "I/O" ? (s.io_valid ? t("inputs current") : t("NOT VALID")) : s.drives_silent.includes(n.name) ? t("SILENT") : t("current")}</td></tr>`) : ""}</table>
      <h3>${t("Bus events (EMCY, heartbeats)")}</h3>
      ${bus.length ? html`<ul data-testid="bus-events">${bus.map(({ e, count }) => html`<li>${time(e)} ${e.text}${count > 1 ? html` <b class="warn">${t("({0} times)", count)}</b>` : ""}</li>`)}</ul>` : html`<p class="hint">${t("none since the HMI started")}</p>`}</div>
    <div class="card wide"><h2>${t("I/O signals")}</h2>
      <div class="signals">${s ? [...s.inputs.map((x) => ({ ...x, dir: "in" })), ...s.outputs.map((x) => ({ ...x, dir: "out" }))].map((x) => html`
        <div class=${`signal ${x.active ? "on" : ""}`} data-signal=${x.name}><span>${x.dir === "in" ? t("in") : t("out")} ${x.bit}</span> ${x.name.replaceAll("_", " ")}</div>`) : "-"}</div></div>
    <${Commissioning} conn=${conn} />
  </section>`;
}
