// Press-and-hold jog keys: a finger on the key starts a continuous jog and renews it every
// RENEW_MS; lifting it, a cancelled touch, losing the pointer, leaving or hiding the page
// release it at once. The server forwards the renewals and the loop's dead-man stops the
// axis when they stop for any other reason (the page or the connection gone).
import { html } from "./ui.mjs";
import { useRef, useEffect } from "preact/hooks";

export const RENEW_MS = 100;

let active = null; // one jog at a time on this page

function stop(conn) {
  if (!active) return;
  clearInterval(active.timer);
  active.el.classList.remove("held");
  conn.forget(active.id);
  active = null;
  conn.send({ t: "jog_release" });
}

export function installReleaseOnLeave(conn) {
  const release = () => stop(conn);
  window.addEventListener("blur", release);
  window.addEventListener("pagehide", release);
  document.addEventListener("visibilitychange", () => {
    if (document.hidden) { release(); conn.send({ t: "visibility", visible: false }); }
  });
}

export function HoldKey({ conn, axis, dir, speed, label, disabled }) {
  const ref = useRef(null);
  useEffect(() => {
    const el = ref.current;
    const down = (ev) => {
      ev.preventDefault();
      if (disabled) return;
      stop(conn);
      try { el.setPointerCapture(ev.pointerId); } catch { /* a synthetic pointer */ }
      const id = conn.newId();
      // The loop answers a jog only when it refuses it: the key goes dark, the reason is
      // shown, and nothing more is renewed.
      conn.onAnswer(id, (a) => {
        if (a.ok) return;
        if (active && active.id === id) stop(conn);
        conn.toast(a, `JOG ${axis.toUpperCase()}${dir}`);
      });
      conn.send({ t: "jog_hold", id, axis, dir, speed: String(speed) });
      el.classList.add("held");
      active = { el, id, timer: setInterval(() => conn.send({ t: "jog_renew" }), RENEW_MS) };
    };
    const up = () => stop(conn);
    el.addEventListener("pointerdown", down);
    for (const t of ["pointerup", "pointercancel", "lostpointercapture"]) el.addEventListener(t, up);
    el.addEventListener("contextmenu", (e) => e.preventDefault());
    return () => {
      el.removeEventListener("pointerdown", down);
      for (const t of ["pointerup", "pointercancel", "lostpointercapture"]) el.removeEventListener(t, up);
    };
  }, [conn, axis, dir, speed, disabled]);
  return html`<button ref=${ref} class="key hold" data-jog=${`${axis}${dir}`} disabled=${disabled}>${label}</button>`;
}
