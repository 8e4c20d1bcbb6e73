// The page's one WebSocket to hob-hmi: hello with the last event seen, then frames, events,
// stats and the answers to commands. Reconnects by itself; a page that gets no frame for
// STALE_MS says the HMI server is not answering and never shows old values as live.

export const STALE_MS = 300;
export const RECONNECT_MS = 500;
export const PLOT_POINTS = 1500; // 60 s at 25 frames a second

export class Conn {
  constructor(path) {
    this.path = path;
    this.listeners = new Set();
    this.pending = new Map();
    this.nextId = 1;
    this.lastEvent = 0;
    this.events = [];
    this.lost = [];
    this.hello = null;
    this.frame = null;
    this.stats = null;
    this.lastFrameAt = 0;
    this.plot = [];
    this.measure = [];
    this.stateChange = [];
    this.stateArrival = [];
    this.paintQueued = false;
    this.connected = false;
    this.ws = null;
    this.open();
    setInterval(() => this.notify(), 200);
  }

  open() {
    const ws = new WebSocket(`ws://${location.host}${this.path}`);
    this.ws = ws;
    ws.onopen = () => {
      this.connected = true;
      ws.send(JSON.stringify({ t: "hello", last_event: this.lastEvent }));
    };
    ws.onmessage = (ev) => this.handle(JSON.parse(ev.data));
    ws.onclose = () => {
      this.connected = false;
      for (const [, p] of this.pending) p({ ok: false, text: "the connection to the HMI server was lost: the command may or may not have reached the loop, look at the state" });
      this.pending.clear();
      setTimeout(() => this.open(), RECONNECT_MS);
      this.notify();
    };
  }

  handle(m) {
    switch (m.t) {
      case "hello":
        this.hello = m;
        break;
      case "frame":
        {
          const before = this.frame && this.frame.state;
          this.frame = m;
          this.lastFrameAt = performance.now();
          // The page paints what a frame brings at the browser's next frame, not on a timer.
          this.paintSoon(m, before && m.state && before.state !== m.state.state ? m.state.state : null);
        }
        if (m.plot) {
          this.plot.push({ c0: m.plot.c0, min: m.plot.min, max: m.plot.max, gap: m.skipped > 0 || m.plot.gap > 0, cut: m.plot.cut });
        } else if (m.skipped > 0 && this.plot.length) {
          this.plot[this.plot.length - 1].gap = true;
        }
        if (this.plot.length > PLOT_POINTS) this.plot.splice(0, this.plot.length - PLOT_POINTS);
        break;
      case "events":
        // By number: an event the page has is never listed twice.
        for (const e of m.list) {
          if (e.seq > this.lastEvent) { this.events.push(e); this.lastEvent = e.seq; }
        }
        if (this.events.length > 2000) this.events.splice(0, this.events.length - 2000);
        break;
      case "events_restart":
        this.events.push({ seq: 0, cycle: 0, kind: "restart", operator: false, text: "the loop restarted: its events are numbered from 1 again" });
        this.lastEvent = 0;
        break;
      case "events_lost":
        this.lost.push(m);
        break;
      case "stats":
        this.stats = m;
        break;
      case "commission":
        // The last view, and each procedure's last (its step, result or refusal).
        this.commission = m;
        this.commissionBy = { ...this.commissionBy, [m.procedure]: m };
        break;
      case "answer": {
        const p = this.pending.get(m.id);
        if (p) { this.pending.delete(m.id); p(m); }
        else this.orphans = [...(this.orphans || []).slice(-9), m];
        break;
      }
    }
    if (m.t !== "frame") this.notify();
  }

  /**
   * Renders at the browser's next frame (one render for frames arriving together). With
   * `latency` set (the HMI's benchmark), measures from the sample's SYNC to the paint: for
   * every frame to the paint after it arrived (`latency`), and for a frame that changed
   * the state to the first paint whose status line shows the new state (`stateChange`): a
   * task queued in the frame's animation callback runs after that frame's paint.
   */
  paintSoon(m, newState) {
    if (this.latency && m.sample_utc_ms) {
      this.measure.push({ sent: m.sample_utc_ms, newState });
      // Its arrival: what the servers took, apart from what the browser takes to paint.
      if (newState !== null) this.stateArrival.push(performance.timeOrigin + performance.now() - m.sample_utc_ms);
    }
    if (this.paintQueued) return;
    this.paintQueued = true;
    requestAnimationFrame(() => {
      this.paintQueued = false;
      this.notify();
      const measured = this.measure;
      this.measure = [];
      if (!measured.length) return;
      setTimeout(() => {
        const now = performance.timeOrigin + performance.now();
        const shown = document.querySelector('[data-testid="state"]');
        for (const x of measured) {
          this.latency.push(now - x.sent);
          if (x.newState === null) continue;
          if (shown && shown.textContent === x.newState) this.stateChange.push(now - x.sent);
          else this.notShown = (this.notShown || 0) + 1;
        }
      }, 0);
    });
  }

  send(obj) {
    if (this.ws && this.ws.readyState === WebSocket.OPEN) { this.ws.send(JSON.stringify(obj)); return true; }
    return false;
  }

  /** A loop command; resolves with the answer {ok, refusal, text}. */
  cmd(op, fields = {}) {
    const id = this.nextId++;
    return new Promise((resolve) => {
      if (!this.send({ t: "cmd", id, op, ...fields })) {
        resolve({ id, ok: false, text: "not connected to the HMI server: nothing was sent" });
        return;
      }
      this.pending.set(id, resolve);
      setTimeout(() => {
        if (this.pending.delete(id)) resolve({ id, ok: false, text: "no answer within 5 s: look at the state before trying again" });
      }, 5000);
    });
  }

  newId() { return this.nextId++; }

  /** Calls `f` with the answer to request `id` if one comes (a jog's: only its refusal). */
  onAnswer(id, f) { this.pending.set(id, f); }

  /** No answer to request `id` is wanted any more (the jog it was is over). */
  forget(id) { this.pending.delete(id); }

  /** The server's frames stopped (killed, network): every value on screen is old. */
  get serverStale() { return !this.connected || performance.now() - this.lastFrameAt > STALE_MS; }

  subscribe(f) { this.listeners.add(f); return () => this.listeners.delete(f); }
  notify() { for (const f of this.listeners) f(); }
}

export async function api(method, path, body) {
  const r = await fetch(path, {
    method,
    headers: body === undefined ? {} : { "content-type": "application/json" },
    body: body === undefined ? undefined : JSON.stringify(body),
  });
  let json = null;
  try { json = await r.json(); } catch { json = { refused: `HTTP ${r.status}` }; }
  return { ok: r.ok, status: r.status, ...json };
}
