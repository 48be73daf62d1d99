// candela web viewer: the live error chart. Every `progress` event carries `rel_mse_estimate`,
// the relMSE against the converged image estimated without a reference (from the even and odd
// halves of the samples); a job that names a reference also gets `metrics` (rel_mse, flip, ssim,
// psnr_db, mse against it). The chart plots the chosen error metric (relMSE by default, FLIP or
// MSE) on a log axis against the elapsed render time, as inline SVG beside the image, with the
// current value labelled, and with relMSE the estimate as a dashed second curve (alone for jobs
// without a reference). Hidden until there is something to plot.

import { $, el, fmtDuration, fmtNum } from './util.js';
import { EventStream } from './api.js';

/** The metrics the chart can plot (errors: lower is better, positive, so a log axis fits). */
export const CHART_METRICS = {
  rel_mse: { label: 'relMSE', long: 'relative mean squared error' },
  flip: { label: 'FLIP', long: 'mean FLIP error' },
  mse: { label: 'MSE', long: 'mean squared error' },
};

const SVG_NS = 'http://www.w3.org/2000/svg';
// Chart geometry in viewBox units: plot area inside the margins.
const W = 320;
const H = 200;
const M = { left: 46, right: 14, top: 12, bottom: 32 };

/** Elapsed seconds of a progress event (SSE progress says elapsed_s, the job JSON time_s). */
const elapsedOf = (p) => p.elapsed_s ?? p.time_s;

/** A value in scientific notation with 3 significant digits (as the label shows it). */
export function fmtMetric(v) {
  if (v == null || !Number.isFinite(v)) return '—';
  if (v === 0) return '0';
  return v >= 0.01 && v < 1000 ? fmtNum(v) : v.toExponential(2);
}

/** Tick positions for [0, max]: steps of 1, 2 or 5 × 10^k, at most ~5 intervals. */
function timeTicks(max) {
  const raw = max / 5;
  const p = 10 ** Math.floor(Math.log10(raw));
  const step = [1, 2, 5, 10].map((f) => f * p).find((s) => s >= raw) || raw;
  const ticks = [];
  for (let t = 0; t <= max * (1 + 1e-9); t += step) ticks.push(t);
  return ticks;
}

function svg(tag, attrs = {}, text) {
  const node = document.createElementNS(SVG_NS, tag);
  for (const [k, v] of Object.entries(attrs)) node.setAttribute(k, String(v));
  if (text != null) node.textContent = text;
  return node;
}

class MetricsChart {
  constructor() {
    this.panel = $('metrics-panel');
    this.svg = $('metrics-chart');
    this.caption = $('metrics-text');
    this.select = $('metrics-metric');
    this.heading = $('metrics-heading');
    this.points = []; // {t, m, e}: elapsed seconds, the metrics object (or null) and the estimate
    this.hasReference = false;
    this.history = null; // EventStream replaying a finished job's progress events
    this.metric = 'rel_mse';
    this.select.addEventListener('change', () => {
      this.metric = CHART_METRICS[this.select.value] ? this.select.value : 'rel_mse';
      this.render();
    });
  }

  /** Forgets the points (another job was selected); shows the panel only for a reference. */
  reset(hasReference) {
    if (this.history) this.history.close();
    this.history = null;
    this.points = [];
    this.hasReference = Boolean(hasReference);
    this.render();
  }

  /** The job's details arrived: whether it names a reference. */
  setReference(hasReference) {
    if (hasReference === this.hasReference) return;
    this.hasReference = Boolean(hasReference);
    this.render();
  }

  /** Adds the metrics and the estimate of one progress event (ignored without either), kept in
   *  time order: a replayed event lands before the job's latest point, one at the same time
   *  replaces it. */
  add(p) {
    const m = p && p.metrics && typeof p.metrics === 'object' ? p.metrics : null;
    const e = p && Number.isFinite(p.rel_mse_estimate) ? p.rel_mse_estimate : null;
    if (!m && e == null) return;
    const t = elapsedOf(p) ?? 0;
    if (!Number.isFinite(t)) return;
    const pts = this.points;
    let i = pts.length;
    while (i > 0 && pts[i - 1].t > t) i--;
    if (i > 0 && pts[i - 1].t === t) pts[i - 1] = { t, m: m || pts[i - 1].m, e: e ?? pts[i - 1].e };
    else pts.splice(i, 0, { t, m, e });
    if (m) this.hasReference = true;
    this.render();
  }

  /** Replays every stored progress event of a job that is no longer rendering, so a finished
   *  job shows its whole curve (the live stream is only opened for running jobs). */
  replay(eventsUrl) {
    if (this.history) this.history.close();
    const stop = () => {
      if (this.history === stream) this.history.close();
      this.history = null;
    };
    const stream = new EventStream(eventsUrl, {
      progress: (d) => {
        if (this.history === stream) this.add(d);
      },
      done: stop,
      error: stop,
      state: (d) => {
        const st = typeof d === 'string' ? d : d && d.state;
        if (st === 'canceled' || st === 'failed') stop();
      },
    }, () => {}, { lastId: '0' });
    this.history = stream;
    // A paused job's stream stays open: stop once the replay had time to arrive.
    setTimeout(() => this.history === stream && stop(), 15000);
  }

  render() {
    // Without a reference only the estimate (a relMSE) can be plotted.
    if (!this.hasReference) this.metric = 'rel_mse';
    this.select.hidden = !this.hasReference;
    const def = CHART_METRICS[this.metric];
    const pts = this.points.filter((q) => q.m && Number.isFinite(q.m[this.metric]) && q.m[this.metric] > 0);
    const est = this.metric === 'rel_mse' ? this.points.filter((q) => q.e > 0) : [];
    this.panel.hidden = !this.hasReference && !est.length;
    this.heading.textContent = this.hasReference ? 'Error against the reference' : 'Estimated error (no reference)';
    this.svg.dataset.metric = this.metric;
    this.svg.dataset.points = String(pts.length);
    this.svg.dataset.estimatePoints = String(est.length);
    const title = svg('title', { id: 'metrics-chart-title' }, `${def.label} against elapsed render time (log scale)`);
    const last = pts[pts.length - 1];
    const lastEst = est[est.length - 1];
    const estText = lastEst
      ? ` Estimated relMSE without a reference (dashed): latest ${fmtMetric(lastEst.e)} at ${fmtDuration(lastEst.t)}.`
      : '';
    const desc = svg('desc', { id: 'metrics-chart-desc' }, (last
      ? `${pts.length} measurement${pts.length === 1 ? '' : 's'} of the ${def.long} against the reference; latest ${fmtMetric(last.m[this.metric])} at ${fmtDuration(last.t)}.`
      : (lastEst ? '' : 'No measurement yet.')) + estText);
    this.svg.setAttribute('aria-labelledby', 'metrics-chart-title metrics-chart-desc');
    const nodes = [title, desc];
    const x0 = M.left;
    const x1 = W - M.right;
    const y0 = M.top;
    const y1 = H - M.bottom;
    nodes.push(svg('rect', { class: 'frame', x: x0, y: y0, width: x1 - x0, height: y1 - y0 }));
    if (!pts.length && !est.length) {
      nodes.push(svg('text', { x: (x0 + x1) / 2, y: (y0 + y1) / 2, 'text-anchor': 'middle', class: 'empty' },
        this.hasReference ? 'Waiting for the first measurement…' : 'No reference'));
      this.svg.replaceChildren(...nodes);
      this.renderCaption();
      return;
    }

    // Axes: log10 of the metric (and the estimate) over whole decades; time from 0 to the last
    // point.
    const logs = pts.map((q) => Math.log10(q.m[this.metric])).concat(est.map((q) => Math.log10(q.e)));
    const lo = Math.floor(Math.min(...logs));
    let hi = Math.ceil(Math.max(...logs));
    if (hi === lo) hi = lo + 1;
    const tMax = Math.max(...pts.concat(est).map((q) => q.t), 1e-3);
    const x = (t) => x0 + (t / tMax) * (x1 - x0);
    const y = (v) => y0 + (1 - (Math.log10(v) - lo) / (hi - lo)) * (y1 - y0);

    const every = Math.ceil((hi - lo) / 6); // at most ~6 labelled decades
    for (let e = lo; e <= hi; e++) {
      const yy = y(10 ** e).toFixed(1);
      nodes.push(svg('line', { class: 'grid', x1: x0, x2: x1, y1: yy, y2: yy }));
      if ((e - lo) % every === 0) {
        nodes.push(svg('text', { class: 'tick', x: x0 - 4, y: Number(yy) + 3, 'text-anchor': 'end' }, `1e${e}`));
      }
    }
    for (const t of timeTicks(tMax)) {
      const xx = x(t).toFixed(1);
      nodes.push(svg('line', { class: 'grid', x1: xx, x2: xx, y1: y0, y2: y1 }));
      nodes.push(svg('text', { class: 'tick', x: xx, y: y1 + 11, 'text-anchor': 'middle' }, `${Number(t.toPrecision(3))}`));
    }
    nodes.push(svg('text', { class: 'axis-title', x: (x0 + x1) / 2, y: H - 4, 'text-anchor': 'middle' }, 'elapsed time (s)'));
    nodes.push(svg('text', {
      class: 'axis-title', x: 10, y: (y0 + y1) / 2, 'text-anchor': 'middle',
      transform: `rotate(-90 10 ${(y0 + y1) / 2})`,
    }, `${def.label} (log)`));

    // The estimate's curve (dashed) and its current value, under the reference curve.
    if (lastEst) {
      const ecoords = est.map((q) => `${x(q.t).toFixed(1)},${y(q.e).toFixed(1)}`);
      nodes.push(svg('polyline', { class: 'line estimate', id: 'metrics-estimate-line', points: ecoords.join(' ') }));
      const ex = x(lastEst.t);
      const ey = y(lastEst.e);
      nodes.push(svg('circle', { class: 'dot estimate', cx: ex.toFixed(1), cy: ey.toFixed(1), r: 2.5 }));
      const estLabel = svg('text', {
        id: 'metrics-estimate-current', class: 'current estimate', x: (ex - 4).toFixed(1),
        y: (ey > y1 - 14 ? ey - 6 : ey + 14).toFixed(1), 'text-anchor': 'end',
      }, `est. ${fmtMetric(lastEst.e)}`);
      estLabel.dataset.value = String(lastEst.e);
      nodes.push(estLabel);
    }
    if (!last) {
      this.svg.replaceChildren(...nodes);
      this.renderCaption();
      return;
    }
    // The curve, its last point and the current value next to it.
    const coords = pts.map((q) => `${x(q.t).toFixed(1)},${y(q.m[this.metric]).toFixed(1)}`);
    nodes.push(svg('polyline', { class: 'line', id: 'metrics-line', points: coords.join(' ') }));
    const lx = x(last.t);
    const ly = y(last.m[this.metric]);
    nodes.push(svg('circle', { class: 'dot', cx: lx.toFixed(1), cy: ly.toFixed(1), r: 2.5 }));
    const current = svg('text', {
      id: 'metrics-current', class: 'current', x: (lx - 4).toFixed(1),
      y: (ly < y0 + 14 ? ly + 12 : ly - 6).toFixed(1), 'text-anchor': 'end',
    }, `${def.label} ${fmtMetric(last.m[this.metric])}`);
    current.dataset.value = String(last.m[this.metric]);
    nodes.push(current);
    this.svg.replaceChildren(...nodes);
    this.renderCaption();
  }

  /** Every metric of the latest measurement, as text under the chart, and the estimate. */
  renderCaption() {
    const withM = this.points.filter((q) => q.m);
    const withE = this.points.filter((q) => q.e != null);
    const last = withM[withM.length - 1];
    const lastEst = withE[withE.length - 1];
    const estimate = lastEst
      ? el('span', { text: `estimated relMSE ${fmtMetric(lastEst.e)} (no reference, dashed)` })
      : null;
    if (!last) {
      if (estimate) this.caption.replaceChildren(estimate, ` at ${fmtDuration(lastEst.t)}`);
      else this.caption.textContent = this.hasReference ? 'Error against the reference appears with the first snapshot.' : '';
      return;
    }
    const m = last.m;
    this.caption.replaceChildren(
      ...(estimate ? [estimate, el('br')] : []),
      el('span', { text: `relMSE ${fmtMetric(m.rel_mse)}` }), ' · ',
      el('span', { text: `FLIP ${fmtMetric(m.flip)}` }), ' · ',
      el('span', { text: `SSIM ${m.ssim == null ? '—' : fmtNum(m.ssim)}` }), ' · ',
      el('span', { text: `PSNR ${m.psnr_db == null ? '—' : fmtNum(m.psnr_db)} dB` }),
      ` at ${fmtDuration(last.t)}`,
    );
  }
}

export const metricsChart = new MetricsChart();
