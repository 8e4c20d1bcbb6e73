// The HMI's figures (a benchmark, not a test): the state-to-screen latency (from a sample's
// SYNC to the browser's next paint after its frame arrived), the command round trip (page
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
  while (Date.now() - t0 < seconds * 1000) {
    await new Promise((r) => setTimeout(r, 5000));
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
