// The plot's pixel merging keeps every spike (node --test, no browser).
import { test } from "node:test";
import assert from "node:assert/strict";
import { toColumns } from "../../web/js/plot-reduce.mjs";

test("a one-point spike survives merging into fewer columns", () => {
  const points = Array.from({ length: 1500 }, (_, i) => ({ min: -1, max: 1, gap: false }));
  points[733] = { min: -2, max: 500, gap: false };
  const cols = toColumns(points, 100);
  assert.ok(cols.length <= 100);
  assert.equal(Math.max(...cols.map((c) => c.max)), 500);
  assert.equal(Math.min(...cols.map((c) => c.min)), -2);
  assert.equal(cols.reduce((n, c) => n + c.n, 0), 1500);
});

test("a gap stays visible in its column and fewer points than columns stay one each", () => {
  const points = [{ min: 0, max: 1, gap: false }, { min: 0, max: 1, gap: true }, { min: 0, max: 1, gap: false }];
  const cols = toColumns(points, 800);
  assert.equal(cols.length, 3);
  assert.deepEqual(cols.map((c) => c.gap), [false, true, false]);
  assert.deepEqual(toColumns([], 10), []);
});
