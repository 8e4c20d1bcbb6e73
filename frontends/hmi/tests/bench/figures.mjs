// The HMI's figures (a benchmark, not a test): the state-to-screen latency (from a sample's
// SYNC to the paint after its frame arrived, for every frame, and for each change of the
// state to the first paint whose status line shows it: the table is jogged back and forth
// every 1.5 s, idle -> jog -> idle), the command round trip (page
// to loop and back, an accepted override), and the browser's JS heap over a run with the
// live plot drawing. Run by bench/system-tests/tests/hmi.rs's `hmi_figures` (ignored,
// not part of ci/test) against the same processes as the browser tests; writes JSON.
import { writeFileSync } from "node:fs";
import { startHmi, browser, need } from "../e2e/lib/hmi.mjs";

const seconds = Number(process.env.HOB_HMI_BENCH_S || 60);
const out = need("HOB_HMI_FIGURES");
const pct = (v, p) => {
  const s = [...v].sort((a, b) => a - b);
  return s.length ? s[Math.min(s.length - 1, Math.floor((p / 100) * s.length))] : null;
};
const summary = (v) => ({ n: v.length, p50: pct(v, 50), p99: pct(v, 99), max: v.length ? Math.max(...v) : null });

const hmi = await startHmi();
// --expose-gc: the live heap after a full collection is what says whether memory is bounded
// (the used heap before it rises and falls with the collector's own schedule).
const ctx = await browser(["--js-flags=--expose-gc"]);
try {
  const page = await ctx.newPage();
  await page.goto(`${hmi.url}#automatic`);
  await page.waitForSelector('[data-testid="age"]', { timeout: 20000 });
  await page.evaluate(() => { window.hobConn.latency = []; });
  const heap = [], live = [];
  const t0 = Date.now();
  let sign = 1, jogs = 0;
  while (Date.now() - t0 < seconds * 1000) {
    for (let i = 0; i < 3; i++) {
      // State changes to measure: the table (it needs no reference) 2 deg each way.
      const r = await page.evaluate((d) => window.hobConn.cmd("jog", { axis: "b", distance: d }), 2 * sign);
      if (r.ok) jogs++;
      sign = -sign;
      await new Promise((res) => setTimeout(res, 1500));
    }
    await new Promise((r) => setTimeout(r, 500));
    const [used, after] = await page.evaluate(() => {
      if (!performance.memory) return [null, null];
      const used = performance.memory.usedJSHeapSize;
      if (window.gc) window.gc();
      return [used, window.gc ? performance.memory.usedJSHeapSize : null];
    });
    heap.push(used);
    live.push(after);
  }
  const latency = await page.evaluate(() => window.hobConn.latency);
  const stateChange = await page.evaluate(() => window.hobConn.stateChange);
  const notShown = await page.evaluate(() => window.hobConn.notShown || 0);
  const arrival = await page.evaluate(() => window.hobConn.stateArrival);
  const rtt = await page.evaluate(async () => {
    const t = [];
    for (let i = 0; i < 200; i++) {
      const a = performance.now();
      const r = await window.hobConn.cmd("override", { what: "feed", percent: 100 });
      if (!r.ok) throw new Error(r.text);
      t.push(performance.now() - a);
    }
    return t;
  });
  const mb = heap.filter((h) => h !== null).map((h) => h / 1048576);
  const liveMb = live.filter((h) => h !== null).map((h) => h / 1048576);
  // The live heap per minute (every 12th sample of 5 s), to see a trend, not only ends.
  const perMinute = liveMb.filter((_, i) => i % 12 === 11).map((v) => Math.round(v * 100) / 100);
  const figures = {
    seconds,
    state_to_screen_ms: summary(latency),
    state_change_to_paint_ms: { ...summary(stateChange), jogs, changes_not_shown_at_their_paint: notShown },
    state_change_arrival_ms: summary(arrival),
    command_round_trip_ms: summary(rtt),
    js_heap_mb: { first: mb[0] ?? null, last: mb[mb.length - 1] ?? null, max: mb.length ? Math.max(...mb) : null, samples: mb.length },
    js_live_heap_after_gc_mb: { first: liveMb[0] ?? null, last: liveMb[liveMb.length - 1] ?? null, max: liveMb.length ? Math.max(...liveMb) : null, per_minute: perMinute },
  };
  writeFileSync(out, JSON.stringify(figures, null, 2));
  console.log(JSON.stringify(figures, null, 2));
} finally {
  await ctx.close();
  hmi.proc.kill("SIGTERM");
}
