// Merging plot points into pixel columns without hiding a spike: each column keeps the
// minimum of the minima and the maximum of the maxima of the points that fall into it,
// and a column that holds a gap (samples or frames lost) says so.

/**
 * @param {{min:number,max:number,gap:boolean}[]} points oldest first
 * @param {number} columns pixel columns available
 * @returns {{min:number,max:number,gap:boolean,cut:boolean,n:number}[]} at most `columns` columns, oldest first
 */
export function toColumns(points, columns) {
  const n = points.length;
  if (n === 0 || columns <= 0) return [];
  const per = Math.max(1, Math.ceil(n / columns));
  const out = [];
  for (let i = 0; i < n; i += per) {
    let min = Infinity, max = -Infinity, gap = false, cut = false, k = 0;
    for (let j = i; j < Math.min(n, i + per); j++) {
      const p = points[j];
      if (p.min < min) min = p.min;
      if (p.max > max) max = p.max;
      gap = gap || p.gap;
      cut = cut || !!p.cut;
      k++;
    }
    out.push({ min, max, gap, cut, n: k });
  }
  return out;
}
