// The view library (Preact with htm: ES modules, no build step) and small shared pieces.
import { h } from "preact";
import htm from "htm";

export const html = htm.bind(h);

// The panel's words (hob-hmi's catalogue, `GET /api/words`): t(msgid, ...values) gives
// the text in the panel's language, `{0}`.. filled with the values; English as written when
// the catalogue has none. Every label the page writes goes through it (a test reads each
// literal call of t and checks lang/de.po has it).
let words = {};
export const lang = { code: "en", languages: [] };
export function t(msgid, ...values) {
  const w = words[msgid] ?? msgid;
  return values.length ? w.replace(/\{(\d)\}/g, (m, i) => (values[i] ?? m)) : w;
}
/** Takes the server's answer of `/api/words` or `/api/language`. */
export function setWords(r) {
  if (!r || !r.ok) return;
  words = r.words || {};
  lang.code = r.lang;
  lang.languages = r.languages || [];
  document.documentElement.lang = r.lang;
}

export const fmt = (x, digits = 3) => (x === null || x === undefined || Number.isNaN(x) ? "-" : Number(x).toFixed(digits));

/** A command button: sends, shows the loop's answer as a toast (refusals in red), or only
 * hands it to `onAnswer` when `quiet` (a panel that keeps the answer in view itself). */
export function CmdButton({ conn, op, fields, label, cls = "", disabled, onAnswer, testid, quiet = false }) {
  const click = async (ev) => {
    const el = ev.currentTarget;
    el.classList.add("busy");
    const a = await conn.cmd(op, fields || {});
    el.classList.remove("busy");
    if (!quiet) conn.toast(a, label);
    if (onAnswer) onAnswer(a);
  };
  // A view-only screen sends no command: its buttons are shown, never active.
  return html`<button class=${`key ${cls}`} data-testid=${testid || `cmd-${op}`} disabled=${disabled || conn.viewOnly} onClick=${click}>${label}</button>`;
}

/** The last two answers, newest first, in their own line under the screen (never over a
 *  control, always the same height): refusals stay until tapped away or another screen. */
export function Toasts({ conn }) {
  const list = (conn.toasts || []).slice(0, 2);
  return html`<div class="toasts" data-testid="answers">${list.map(
    (a) => html`<div class=${`toast ${a.ok ? "ok" : "refused"}`} data-testid="toast" data-refusal=${a.refusal || ""} onClick=${() => conn.dismiss(a.key)}>
      <b>${a.label}:</b> ${a.ok ? a.text || t("accepted") : html`${t("REFUSED:")} ${a.text}`}</div>`,
  )}</div>`;
}

/** The panel's user level and what it may, from the server's hello (`hob-hmi --level`, at
 *  most its user's level at the gateway): one line at the top of every screen. The server
 *  refuses what the level may not; the page only says it. */
export function LevelNote({ conn }) {
  const l = conn.hello && conn.hello.level;
  if (!l) return "";
  const may = l.may.filter((w) => w !== "watch the machine");
  return html`<p class="level" data-testid="level-note"><b data-testid="level" data-level=${l.name}>${t(l.name).toUpperCase()}</b> ${t("may")} ${(may.length ? may : ["watch the machine"]).map((w) => t(w)).join(", ")}${l.may_not.length ? html`; <span class="not">${t("not")} ${l.may_not.map((w) => t(w)).join(", ")}</span>` : ""}</p>`;
}

/** Whether the panel's level may `action` (`edit_tools`, `compensate`, ...). */
export const allows = (conn, action) => !!(conn.hello && conn.hello.level && conn.hello.level.allows[action]);
