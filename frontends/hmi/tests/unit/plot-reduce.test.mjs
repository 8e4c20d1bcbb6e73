// The plot's pixel merging keeps every spike (node --test, no browser).
import { test } from "node:test";
import assert from "node:assert/strict";
import { toTimeColumns, plotSpan, timeTicks } from "../../web/js/plot-reduce.mjs";

test("a one-point spike survives merging into fewer columns, a gap stays in its column", () => {
  const points = Array.from({ length: 1500 }, (_, i) => ({ c0: 40 * i, min: -1, max: 1, gap: i === 900, cut: true }));
  points[733] = { ...points[733], min: -2, max: 500 };
  const cols = toTimeColumns(points, 60000, 600, 100);
  assert.equal(cols.length, 100);
  assert.equal(Math.max(...cols.map((c) => c.max)), 500);
  assert.equal(Math.min(...cols.map((c) => c.min)), -2);
  assert.equal(cols.reduce((n, c) => n + c.n, 0), 1500);
  assert.equal(cols.filter((c) => c.gap).length, 1);
  assert.deepEqual(toTimeColumns([], 0, 10, 3), [null, null, null]);
});

test("the newest point is at the right edge, however few points there are (it sat at 75 %)", () => {
  // 10 s of points at 25 Hz (every 40 cycles of 1 ms) in a 60 s window of 600 columns.
  const points = Array.from({ length: 250 }, (_, i) => ({ c0: 100000 + 40 * i, min: 0, max: 1, gap: false, cut: true }));
  const now = points[points.length - 1].c0 + 40;
  const cols = toTimeColumns(points, now, 100, 600);
  assert.equal(cols.length, 600);
  assert.ok(cols[599], "the last column holds the newest point");
  assert.equal(cols.slice(0, 499).filter(Boolean).length, 0, "50 s before them: empty");
  assert.equal(cols.reduce((n, c) => n + (c ? c.n : 0), 0), 250);
});

test("a spike outside the cut does not rescale the cut", () => {
  const cut = { min: -2, max: 2, gap: false, cut: true, n: 1 };
  const engaging = { min: -70, max: 7, gap: false, cut: false, n: 1 };
  assert.equal(plotSpan([cut, null, engaging, cut], 4), 6);
  assert.equal(plotSpan([{ ...cut, max: 9 }, engaging], 4), 9);
  assert.equal(plotSpan([engaging, null], 4), 70, "no cut on the plot: every point counts");
});

test("time ticks every 10 s of a 60 s window end at now", () => {
  assert.deepEqual(timeTicks(60, 10).map((t) => t.label), ["now", "-10 s", "-20 s", "-30 s", "-40 s", "-50 s", "-60 s"]);
});
