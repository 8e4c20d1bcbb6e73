// The touch keypad for numbers: it opens over the navigation column (not needed while
// typing; nothing of the screen is covered) when a number field (inputmode decimal) takes
// the focus, and types into that field as a finger would: digits, a decimal comma, a sign;
// ENTER, or a tap on anything else, closes it. Its keys never take the focus from the
// field. It checks nothing: the field's text goes to the server as typed, read by the Rust
// code the CLI uses.
import { useState, useEffect } from "preact/hooks";
import { html, t } from "./ui.mjs";

const KEYS = ["7", "8", "9", "4", "5", "6", "1", "2", "3", ",", "0", "−", "⌫", "CLEAR", "ENTER"];

const isNumberField = (el) => el && el.tagName === "INPUT" && el.inputMode === "decimal" && !el.readOnly && !el.disabled;

/** Puts `text` into the field as typing does (the page's onInput sees it). */
function setText(el, text) {
  el.value = text;
  el.dispatchEvent(new Event("input", { bubbles: true }));
}

export function Keypad() {
  const [field, setField] = useState(null);
  useEffect(() => {
    const focus = (e) => setField(isNumberField(e.target) ? e.target : null);
    // A tap elsewhere (not on the keypad) closes it with the field's focus.
    const blur = (e) => { if (!e.relatedTarget || !e.relatedTarget.closest(".keypad")) setField(null); };
    document.addEventListener("focusin", focus);
    document.addEventListener("focusout", blur);
    return () => { document.removeEventListener("focusin", focus); document.removeEventListener("focusout", blur); };
  }, []);
  if (!field || !field.isConnected) return "";
  const press = (k) => {
    const v = field.value;
    if (k === "ENTER") { field.blur(); setField(null); return; }
    if (k === "CLEAR") setText(field, "");
    else if (k === "⌫") setText(field, v.slice(0, -1));
    else if (k === "−") setText(field, v.startsWith("-") ? v.slice(1) : `-${v}`);
    else setText(field, v + k);
  };
  return html`<div class="keypad" data-testid="keypad" onPointerDown=${(e) => e.preventDefault()} onMouseDown=${(e) => e.preventDefault()}>
    ${KEYS.map((k) => html`<button class=${`key pad ${k === "ENTER" ? "primary" : ""}`} tabindex="-1" data-key-pad=${k} onClick=${() => press(k)}>${k === "CLEAR" ? t("CLEAR") : k === "ENTER" ? t("ENTER") : k}</button>`)}
  </div>`;
}
