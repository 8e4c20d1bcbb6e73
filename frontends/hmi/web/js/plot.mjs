// The live plot of the synchronisation error along the cut: a fixed time window ending at
// "now" on the right edge, with a time axis; one vertical bar per pixel column from the
// minimum to the maximum of its points (a one-cycle spike shows; plot-reduce.mjs), the
// bound drawn in, gaps marked. The scale comes from the cut: a spike while engaging or
// leaving is drawn clipped at the edge, in grey, not rescaling the cut.
import { html, t } from "./ui.mjs";
import { useRef, useEffect } from "preact/hooks";
import { toTimeColumns, plotSpan, timeTicks } from "./plot-reduce.mjs";

export const WINDOW_S = 60;
const LEFT = 50, BOTTOM = 20;

export function SyncPlot({ points, bound, version, periodUs }) {
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
    const plotW = w - LEFT, plotH = hgt - BOTTOM;
    const cyclesPerS = 1e6 / (periodUs || 1000);
    const perColumn = (WINDOW_S * cyclesPerS) / Math.max(1, plotW);
    const last = points.length ? points[points.length - 1].c0 : 0;
    const cols = toTimeColumns(points, last + 1, perColumn, plotW);
    const span = plotSpan(cols, bound);
    const y = (v) => plotH / 2 - (Math.max(-span, Math.min(span, v)) / span) * (plotH / 2 - 8);
    g.strokeStyle = "#445"; g.beginPath(); g.moveTo(LEFT, y(0)); g.lineTo(w, y(0)); g.stroke();
    g.fillStyle = "#ccd"; g.font = "14px sans-serif";
    g.fillText(`${span.toFixed(1)}"`, 4, 16); g.fillText(`${(-span).toFixed(1)}"`, 4, plotH - 6);
    // The time axis: seconds before now.
    g.strokeStyle = "#34475a"; g.fillStyle = "#8fa3b5";
    for (const tick of timeTicks(WINDOW_S, 10)) {
      const x = w - 1 - (tick.ago_s / WINDOW_S) * (plotW - 1);
      g.beginPath(); g.moveTo(x, 0); g.lineTo(x, plotH); g.stroke();
      const label = tick.ago_s === 0 ? t("now") : tick.label;
      const tw = g.measureText(label).width;
      g.fillText(label, Math.max(LEFT, Math.min(w - tw, x - tw / 2)), hgt - 4);
    }
    if (bound) {
      g.strokeStyle = "#e0a030"; g.setLineDash([6, 4]);
      for (const b of [bound, -bound]) { g.beginPath(); g.moveTo(LEFT, y(b)); g.lineTo(w, y(b)); g.stroke(); }
      g.setLineDash([]);
      g.fillStyle = "#e0a030"; g.fillText(t("bound ±{0}\" in the cut", bound.toFixed(1)), LEFT + 4, y(bound) - 4);
    }
    cols.forEach((p, i) => {
      if (!p) return;
      const x = LEFT + i;
      if (p.gap) { g.fillStyle = "#553"; g.fillRect(x, 0, 1, plotH); }
      // The bound holds in the cut; engaging, leaving and idle are drawn grey.
      const over = p.cut && bound && (Math.abs(p.min) > bound || Math.abs(p.max) > bound);
      g.fillStyle = !p.cut ? "#6a7885" : over ? "#ff5050" : "#50d0ff";
      g.fillRect(x, y(p.max), 1, Math.max(1, y(p.min) - y(p.max)));
    });
  }, [version, bound, periodUs]);
  return html`<canvas ref=${ref} class="plot" data-testid="sync-plot" data-window-s=${WINDOW_S}></canvas>`;
}
