// Merging plot points into pixel columns without hiding a spike: each column keeps the
// minimum of the minima and the maximum of the maxima of the points that fall into it,
// and a column that holds a gap (samples or frames lost) says so.

/**
 * Points into a fixed time window: column i of `columns` holds the cycles from
 * `now - (columns - i) * perColumn` up to the next column's, so the newest point is in the
 * last column ("now" at the right edge) and an empty column (no point there yet) is null.
 * @param {{c0:number,min:number,max:number,gap:boolean,cut:boolean}[]} points oldest first
 * @param {number} nowCycle the newest cycle
 * @param {number} perColumn cycles per pixel column
 * @param {number} columns pixel columns
 */
export function toTimeColumns(points, nowCycle, perColumn, columns) {
  const out = new Array(Math.max(0, columns)).fill(null);
  if (columns <= 0 || perColumn <= 0) return out;
  const start = nowCycle - columns * perColumn;
  for (const p of points) {
    const i = Math.floor((p.c0 - start) / perColumn);
    if (i < 0 || i >= columns) continue;
    const c = out[i];
    if (!c) out[i] = { min: p.min, max: p.max, gap: !!p.gap, cut: !!p.cut, n: 1 };
    else {
      c.min = Math.min(c.min, p.min); c.max = Math.max(c.max, p.max);
      c.gap = c.gap || !!p.gap; c.cut = c.cut || !!p.cut; c.n++;
    }
  }
  return out;
}

/**
 * The plot's half-height, arcsec: from the columns in the cut (where the bound applies),
 * at least 1.5 times the bound; a spike outside the cut (engaging, leaving) is drawn
 * clipped at the edge instead of rescaling the cut. Without a cut column, from all.
 */
export function plotSpan(cols, bound) {
  const present = cols.filter(Boolean);
  const inCut = present.filter((c) => c.cut);
  let span = bound ? bound * 1.5 : 1;
  for (const c of inCut.length ? inCut : present) span = Math.max(span, Math.abs(c.min), Math.abs(c.max));
  return span;
}

/** Ticks every `stepS` seconds over a window of `windowS` seconds, ending at "now". */
export function timeTicks(windowS, stepS) {
  const out = [];
  for (let s = 0; s <= windowS + 1e-9; s += stepS) out.push({ ago_s: s, label: s === 0 ? "now" : `-${s} s` });
  return out;
}
