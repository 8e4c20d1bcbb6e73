// The HMI page: the status line (always visible), the screens of the thesis's operator
// interface, and one connection to hob-hmi. Every button is a loop command or a library
// call; every message shown is the loop's or the Rust checks' own text.
import { render } from "preact";
import { useState, useEffect } from "preact/hooks";
import { html, fmt, t, lang, setWords, CmdButton, Toasts, LevelNote } from "./ui.mjs";
import { Conn, api } from "./conn.mjs";
import { installReleaseOnLeave } from "./hold.mjs";
import { Keypad } from "./keypad.mjs";
import { PowerUp, Jog, Automatic, Single, Alarms, Diagnostics, Report } from "./screens.mjs";
import { Programs, Definition } from "./library.mjs";
import { Compensate } from "./compensate.mjs";

// The panel's socket, or the view-only one where the server says so (its page's meta).
const socket = document.querySelector('meta[name="hob-socket"]').content;
// The panel's words before the first paint (English as written if the server has none).
setWords(await api("GET", "/api/words").catch(() => null));
const conn = new Conn(socket);
conn.viewOnly = socket === "/ws/view";
conn.toasts = [];
let toastKey = 1;
conn.toast = (a, label) => {
  conn.toasts = [{ ...a, label, key: toastKey++ }, ...conn.toasts].slice(0, 4);
  const key = conn.toasts[0].key;
  if (a.ok) setTimeout(() => conn.dismiss(key), 4000);
  conn.notify();
};
conn.dismiss = (key) => { conn.toasts = conn.toasts.filter((t) => t.key !== key); conn.notify(); };
installReleaseOnLeave(conn);
// For the HMI's benchmark (frontends/hmi/tests/bench/figures.mjs): the page's connection.
window.hobConn = conn;

// A view-only screen (another PC in the shop) shows what runs, never a command or a change.
const VIEW_SCREENS = ["automatic", "report", "alarms", "diagnostics"];
const ALL_SCREENS = [
  ["powerup", () => t("POWER-UP")], ["jog", () => t("JOG")], ["programs", () => t("PROGRAMS")], ["definition", () => t("DEFINITION")],
  ["single", () => t("SINGLE")], ["automatic", () => t("AUTOMATIC")], ["report", () => t("REPORT")], ["compensate", () => t("COMPENSATE")], ["alarms", () => t("ALARMS")],
  ["diagnostics", () => t("DIAGNOSTICS")],
];
const SCREENS = conn.viewOnly ? ALL_SCREENS.filter(([k]) => VIEW_SCREENS.includes(k)) : ALL_SCREENS;

function Status({ conn }) {
  const f = conn.frame, s = f && f.state;
  const stale = conn.serverStale;
  const silent = f && f.silent_ms !== null && f.silent_ms !== undefined;
  let age;
  if (stale) age = html`<span class="bad" data-testid="stale">${t("HMI SERVER NOT ANSWERING: the values below are old")}</span>`;
  else if (!s) age = html`<span class="bad" data-testid="stale">${t("NO DATA FROM THE LOOP (is hob-rt running?)")}</span>`;
  else if (silent) age = html`<span class="bad" data-testid="stale">${t("NO DATA FROM THE LOOP for {0} s: the values below are old", (f.silent_ms / 1000).toFixed(1))}</span>`;
  else age = html`<span class="ok" data-testid="age">${t("live, {0} ms old", fmt(f.loop_age_ms, 1))}</span>`;
  const ov = s && (s.feed_override_percent !== 100 || s.spindle_override_percent !== 100);
  // One line of fixed height that never wraps (a FEED HOLD or an override appearing moved
  // everything under the finger by 41 px), and under it the alarms, at most 132 px high,
  // scrolling inside (a 260 px banner pushed the navigation off the screen).
  return html`<header class=${`status ${stale || silent || !s ? "is-stale" : ""}`} data-testid="status"><div class="st-line">
    <div class="st-state"><span class="label">${t("state")}</span><b data-testid="state" data-state=${s ? s.state : ""}>${s ? t(s.state_words) : "-"}</b>${s && s.hold ? html` <b class="warn">${t("FEED HOLD")}</b>` : ""}</div>
    <div><span class="label">${t("pass")}</span><b data-testid="pass">${s && s.passes ? t("{0} of {1}", s.pass, s.passes) : "-"}</b></div>
    <div class="st-program"><span class="label">${t("program")}</span><b data-testid="loaded-program">${!s ? "-" : !s.program_loaded ? t("none") : f.loaded_here ? (f.changed_since_load ? html`${f.loaded_here} <span class="warn" data-testid="changed-since-load">${t("CHANGED SINCE LOAD")}</span>` : f.loaded_here) : html`<span class="warn">${t("loaded elsewhere (plan unknown here)")}</span>`}</b></div>
    <div><span class="label">${t("reference")}</span><b data-testid="referenced">X ${s && s.referenced.x ? "✓" : "✗"} Y ${s && s.referenced.y ? "✓" : "✗"}</b></div>
    ${ov ? html`<div class="warn" data-testid="overrides">${t("feed {0} % hob {1} %", fmt(s.feed_override_percent, 0), fmt(s.spindle_override_percent, 0))}</div>` : ""}
    <div class="age">${age}</div>
    <div class="st-lang">${lang.languages.length > 1 && !conn.viewOnly ? html`<${LanguageKey} conn=${conn} />` : ""}</div>
    <div class="st-reset">${conn.viewOnly ? html`<b class="warn" data-testid="view-only">${t("VIEW ONLY")}</b>` : html`<${CmdButton} conn=${conn} op="reset" label=${t("RESET")} cls="reset" />`}</div></div>
    ${(s && s.alarm) || (f && f.recorder && f.recorder.alarm) ? html`<div class="st-alarms" data-testid="alarms-bar">
    ${s && s.alarm ? html`<div class="alarm" data-testid="alarm">
      <div><b>${t("ALARM")}</b> ${s.alarm.text}${s.alarm.drive_reported ? html`: <b data-testid="alarm-drive-reported">${s.alarm.drive_reported}</b>` : ""}</div>
      <div><span class="label">${t("the machine")}</span> ${s.alarm.reaction}</div>
      <div><span class="label">${t("remedy")}</span> ${s.alarm.remedy}</div>
      <div><span class="label">${t("to continue")}</span> ${s.alarm.how_to_continue}</div></div>` : ""}
    ${f && f.recorder && f.recorder.alarm ? html`<div class="alarm" data-testid="recorder-alarm"><b>${t("RECORDER")}</b> ${f.recorder.text}</div>` : ""}</div>` : ""}
  </header>`;
}

/** The panel's language key: the next language this panel has, by its own name; the server
 *  translates what it sends from then on, the page its labels at once. */
function LanguageKey({ conn }) {
  const i = lang.languages.findIndex((l) => l.code === lang.code);
  const next = lang.languages[(i + 1) % lang.languages.length];
  const change = async () => { setWords(await api("POST", "/api/language", { lang: next.code })); conn.notify(); };
  return html`<button class="key small" data-testid="language" data-lang=${lang.code} title=${t("language")} onClick=${change}>${next.name}</button>`;
}

function App() {
  const [, setTick] = useState(0);
  const first = conn.viewOnly ? "automatic" : "powerup";
  const asked = location.hash.slice(1);
  const [screen, setScreen] = useState(SCREENS.some(([k]) => k === asked) ? asked : first);
  const [program, setProgram] = useState(null); // the library program being defined/loaded
  // Renders when the connection says so: each frame at the browser's next paint, each
  // answer and event at once, and every 200 ms for the ages and the stale mark.
  useEffect(() => conn.subscribe(() => setTick((t) => t + 1)), []);
  // An answer belongs to the screen its command was given on: another screen starts clean.
  const go = (s) => { if (s !== screen) { conn.toasts = []; } setScreen(s); location.hash = s; };
  const props = { conn, program, setProgram, go };
  const body = {
    powerup: PowerUp, jog: Jog, programs: Programs, definition: Definition, single: Single,
    automatic: Automatic, report: Report, compensate: Compensate, alarms: Alarms, diagnostics: Diagnostics,
  }[screen] || (conn.viewOnly ? Automatic : PowerUp);
  return html`<div class="shell">
    <${Status} conn=${conn} />
    <nav>${SCREENS.map(([k, label]) => html`<button class=${`nav ${k === screen ? "on" : ""}`} data-screen=${k} onClick=${() => go(k)}>${label()}</button>`)}</nav>
    <main data-testid=${`screen-${screen}`}>${conn.viewOnly ? "" : html`<${LevelNote} conn=${conn} />`}<${body} ...${props} /></main>
    <${Toasts} conn=${conn} />
    <${Keypad} />
  </div>`;
}

render(html`<${App} />`, document.getElementById("app"));
