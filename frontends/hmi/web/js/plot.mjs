// The live plot of the synchronisation error along the cut: one vertical bar per point from
// the interval's minimum to its maximum (a one-cycle spike shows), merged into pixel columns
// the same way (plot-reduce.mjs), the bound drawn in, gaps marked.
import { html } from "./ui.mjs";
import { useRef, useEffect } from "preact/hooks";
import { toColumns } from "./plot-reduce.mjs";

export function SyncPlot({ points, bound, version }) {
  const ref = useRef(null);
  useEffect(() => {
    const c = ref.current;
    if (!c) return;
    const w = c.clientWidth, hgt = c.clientHeight;
    if (c.width !== w) c.width = w;
    if (c.height !== hgt) c.height = hgt;
    const g = c.getContext("2d");
    g.fillStyle = "#10161c";
    g.fillRect(0, 0, w, hgt);
    const cols = toColumns(points, w - 50);
    let span = bound ? bound * 1.5 : 1;
    for (const p of cols) span = Math.max(span, Math.abs(p.min), Math.abs(p.max));
    const y = (v) => hgt / 2 - (v / span) * (hgt / 2 - 8);
    g.strokeStyle = "#445"; g.beginPath(); g.moveTo(50, y(0)); g.lineTo(w, y(0)); g.stroke();
    g.fillStyle = "#ccd"; g.font = "14px sans-serif";
    g.fillText(`${span.toFixed(1)}"`, 4, 16); g.fillText(`${(-span).toFixed(1)}"`, 4, hgt - 6);
    if (bound) {
      g.strokeStyle = "#e0a030"; g.setLineDash([6, 4]);
      for (const b of [bound, -bound]) { g.beginPath(); g.moveTo(50, y(b)); g.lineTo(w, y(b)); g.stroke(); }
      g.setLineDash([]);
      g.fillStyle = "#e0a030"; g.fillText(`bound ±${bound.toFixed(1)}" in the cut`, 4, y(bound) - 4);
    }
    cols.forEach((p, i) => {
      const x = 50 + i;
      if (p.gap) { g.fillStyle = "#553"; g.fillRect(x, 0, 1, hgt); }
      // The bound holds in the cut; engaging, leaving and idle are drawn grey.
      const over = p.cut && bound && (Math.abs(p.min) > bound || Math.abs(p.max) > bound);
      g.fillStyle = !p.cut ? "#6a7885" : over ? "#ff5050" : "#50d0ff";
      g.fillRect(x, y(p.max), 1, Math.max(1, y(p.min) - y(p.max)));
    });
  }, [version, bound]);
  return html`<canvas ref=${ref} class="plot" data-testid="sync-plot"></canvas>`;
}
