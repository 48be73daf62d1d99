// candela web viewer: the selected job, live over SSE (snapshots, progress statistics, the error
// chart against a reference), downloads, exposure and tonemap.

import { $, STORE, TERMINAL, debounce, el, fmtDuration, fmtNum, fmtSi } from './util.js';
import { EventStream, api, authHeaders, getToken, toApiError, withQuery } from './api.js';
import {
  emit, on, state, elapsedOf, jobFraction, jobId, jobLinks, jobName, jobNumbers, jobProgress, jobSettings, jobSpp,
  jobHasReference,
} from './state.js';
import { ImageSlot, availHeight, fitBox } from './images.js';
import { refreshJobs, renderJobRow, renderJobs, upsertJob } from './jobs.js';
import { metricsChart } from './chart.js';

// ---------------------------------------------------------------------------------------------
// Viewer: the selected job, live over SSE
// ---------------------------------------------------------------------------------------------

export const viewSlot = new ImageSlot(
  $('view-image'),
  () => {
    $('view-image').hidden = false;
    $('stage-placeholder').hidden = true;
    fitViewImage();
    updateDownloads();
  },
  (err) => {
    if (!$('view-image').getAttribute('src')) {
      $('stage-placeholder').hidden = false;
      $('stage-placeholder').textContent = err.status === 404 ? 'Waiting for the first snapshot…' : `No image: ${err.describe ? err.describe() : err.message}`;
    }
  },
);

export function toneParams() {
  return { exposure: state.tone.exposure, tonemap: state.tone.tonemap };
}

/** PNG URL of a job (or of a snapshot URL) with the current exposure and tonemap. Requests
 *  are made with cache: 'no-store', so the same URL fetches the newest snapshot each time. */
export function pngUrl(job, snapshotUrl) {
  return withQuery(snapshotUrl || jobLinks(job).png, toneParams());
}

export function selectJob(id, { force = false } = {}) {
  if (state.selected === id && !force) {
    $('viewer').focus({ preventScroll: true });
    return;
  }
  if (state.stream) state.stream.close();
  state.stream = null;
  state.selected = id;
  state.live = null;
  state.auto = null;
  state.snapshotUrl = null;
  const known = state.jobs.get(id);
  metricsChart.reset(known && jobHasReference(known));
  viewSlot.reset();
  $('view-image').hidden = true;
  $('stage-placeholder').hidden = false;
  $('stage-placeholder').textContent = 'Loading…';
  $('view-message').textContent = '';
  history.replaceState(null, '', `#job=${encodeURIComponent(id)}`);
  emit('job-selected', id);
  renderJobs();

  if (known) renderViewHeader(known);
  api(`/api/jobs/${encodeURIComponent(id)}`)
    .then((job) => {
      if (state.selected !== id) return;
      upsertJob(job);
      renderViewHeader(job);
      renderStats(job, jobNumbers(job));
      metricsChart.setReference(jobHasReference(job));
      metricsChart.add(jobProgress(job));
      if (TERMINAL.has(job.state)) metricsChart.replay(jobLinks(job).events);
      if (jobSpp(job) > 0 || job.state === 'done') viewSlot.load(pngUrl(job), { spp: jobSpp(job), job: id });
      else $('stage-placeholder').textContent = job.state === 'queued' ? 'Queued: waiting for the GPU…' : 'Waiting for the first snapshot…';
      if (!TERMINAL.has(job.state)) openStream(job);
    })
    .catch((err) => {
      if (state.selected !== id) return;
      $('stage-placeholder').textContent = `Cannot load job ${id}: ${err.describe ? err.describe() : err.message}`;
    });
}

export function openStream(job) {
  const id = jobId(job);
  const current = () => state.jobs.get(id) || job;
  const mine = () => state.selected === id && state.stream === stream;
  let finishTimer = 0;

  // The job ended well: final statistics and the final image, then the stream is closed.
  const finish = (d) => {
    clearTimeout(finishTimer);
    const j = { ...current(), state: 'done' };
    if (d && typeof d === 'object' && d.progress) j.progress = d.progress;
    upsertJob(j);
    renderViewHeader(j);
    const final = { ...jobNumbers(j), ...(state.live || {}) };
    if (d && typeof d === 'object') {
      // done carries {spp, stats}: the final RenderStats (time_s is the whole render time).
      Object.assign(final, d.progress || {}, d.stats || {});
      if (d.stats && d.stats.time_s != null) final.elapsed_s = d.stats.time_s;
      if (d.spp != null) final.spp = d.spp;
    }
    state.live = final;
    renderStats(j, final);
    renderJobs();
    viewSlot.load(pngUrl(j), { spp: final.spp ?? jobSpp(j), job: id, final: 'true' });
    $('view-message').textContent = `Done: ${final.spp ?? jobSpp(j)} samples per pixel in ${fmtDuration(elapsedOf(final))}.`;
    closeStream(id);
  };

  const finishSoon = () => {
    if (!finishTimer) finishTimer = setTimeout(() => mine() && finish(null), 2000);
  };

  const stream = new EventStream(jobLinks(job).events, {
    state: (d) => {
      if (!mine()) return;
      const st = typeof d === 'string' ? d : d.state;
      const j = { ...current(), state: st };
      if (d && d.error) j.error = d.error;
      upsertJob(j);
      renderViewHeader(j);
      renderJobs();
      if (st === 'running' && !$('view-image').getAttribute('src')) $('stage-placeholder').textContent = 'Waiting for the first snapshot…';
      if (st === 'queued' && !$('view-image').getAttribute('src')) $('stage-placeholder').textContent = 'Queued: waiting for the GPU…';
      // "done" is followed by a done event with the final numbers; wait a little for it.
      if (st === 'done') finishSoon();
      else if (TERMINAL.has(st)) {
        if (st === 'canceled') $('view-message').textContent = 'Canceled.';
        closeStream(id);
      }
    },
    progress: (d) => {
      if (!mine()) return;
      state.live = d;
      renderStats(current(), d);
      metricsChart.add(d);
      renderJobRow(id);
    },
    // An `auto` job's choice, once its pilot has run (also in the final stats.auto).
    auto: (d) => {
      if (!mine()) return;
      state.auto = d;
      renderAuto(d);
    },
    snapshot: (d) => {
      if (!mine()) return;
      state.snapshotUrl = d.url || null;
      viewSlot.load(pngUrl(current(), d.url), { spp: d.spp ?? '', job: id });
    },
    done: (d) => {
      if (mine()) finish(d);
    },
    error: (d) => {
      if (!mine()) return;
      const message = (d && (d.message || (d.error && d.error.message))) || String(d);
      const j = { ...current(), state: 'failed', error: { message } };
      upsertJob(j);
      renderViewHeader(j);
      renderJobs();
      $('view-message').textContent = `Render failed: ${message}`;
      closeStream(id);
    },
  }, (status) => {
    if (mine()) $('view-message').textContent = status;
    // With a reference, replay every stored event so the error chart has the whole curve.
    // An auto job replays them too, for its `auto` event.
  }, { lastId: jobHasReference(job) || jobSettings(job).auto ? '0' : null });
  stream.finishSoon = finishSoon;
  state.stream = stream;
}

export function closeStream(id) {
  if (state.selected === id && state.stream) {
    state.stream.close();
    state.stream = null;
  }
  refreshJobs();
}

/** Keeps the viewer consistent with the polled list (e.g. a state change while reconnecting). */
export function syncSelectedFromList() {
  const id = state.selected;
  const job = id && state.jobs.get(id);
  if (!job) return;
  renderViewHeader(job);
  if (!state.live) renderStats(job, jobNumbers(job));
  if (!state.stream && !TERMINAL.has(job.state)) openStream(job);
  else if (state.stream && job.state === 'done') state.stream.finishSoon();
  else if (state.stream && TERMINAL.has(job.state)) closeStream(id);
}

export function renderViewHeader(job) {
  const st = job.state || '';
  $('view-title').textContent = `${jobName(job)}`;
  const badge = $('view-state');
  badge.hidden = !st;
  badge.textContent = st;
  badge.className = `badge state-${st}`;
  badge.dataset.state = st;
  if (st === 'failed' && job.error) $('view-message').textContent = `Render failed: ${job.error.message || job.error}`;
  updateDownloads();
}

export function renderStats(job, p) {
  const s = jobSettings(job);
  $('stat-spp').textContent = s.spp ? `${p.spp ?? 0} / ${s.spp}` : `${p.spp ?? 0}`;
  $('stat-elapsed').textContent = fmtDuration(elapsedOf(p));
  $('stat-msps').textContent = fmtNum(p.msamples_per_s);
  $('stat-rays').textContent = fmtSi(p.rays_per_s);
  $('stat-eta').textContent = job.state === 'done' ? 'done'
    : TERMINAL.has(job.state) ? '—'
      : job.state === 'paused' ? 'paused' : fmtDuration(p.eta_s);
  $('stat-dropped').textContent = p.dropped_samples != null ? String(p.dropped_samples) : '—';
  const frac = jobFraction(job, p);
  const bar = $('view-progress');
  if (frac == null) bar.removeAttribute('value');
  else bar.value = frac;
  $('stats').dataset.spp = String(p.spp ?? 0);
  renderAuto(p.auto || state.auto);
}

/** An `auto` job's choice ({choice, pilots}: the `auto` event, stats.auto): the integrator
 *  chosen and each pilot's cost (estimated relMSE × seconds); hidden for other jobs. */
export function renderAuto(choice) {
  const row = $('stat-auto-row');
  row.hidden = !choice;
  if (!choice) return;
  const pilots = (choice.pilots || []).map((p) => `${p.integrator} ${p.cost == null ? '—' : p.cost.toExponential(1)}`);
  $('stat-auto').textContent = `${choice.choice} (cost relMSE·s: ${pilots.join(', ')})`;
  $('stat-auto').dataset.choice = choice.choice;
}

export function fitViewImage() {
  const img = $('view-image');
  const stage = $('stage');
  if (!img.naturalWidth) return;
  const box = fitBox(img.naturalWidth, img.naturalHeight, stage.clientWidth - 2, availHeight());
  img.style.width = `${box.w}px`;
  img.style.height = `${box.h}px`;
  img.classList.toggle('pixelated', box.pixelated);
  const job = state.jobs.get(state.selected);
  img.alt = job ? `Render of ${jobName(job)} at ${img.dataset.spp || '?'} samples per pixel` : 'Render';
}

/** Refits the image whenever the stage's width changes (window resize, the error chart shown or
 *  hidden beside it), and follows the job list's events. */
export function initViewer() {
  on('open-job', (id) => selectJob(id));
  on('jobs-refreshed', syncSelectedFromList);
  on('job-changed', (job) => {
    if (state.selected === jobId(job)) renderViewHeader(job);
  });
  let lastWidth = 0;
  new ResizeObserver(() => {
    const w = $('stage').clientWidth;
    if (w === lastWidth) return;
    lastWidth = w;
    fitViewImage();
  }).observe($('stage'));
}

export function updateDownloads() {
  const job = state.jobs.get(state.selected);
  const png = $('download-png');
  const exr = $('download-exr');
  const ready = Boolean(job && (jobSpp(job) > 0 || job.state === 'done' || $('view-image').getAttribute('src')));
  for (const a of [png, exr]) {
    a.setAttribute('aria-disabled', String(!ready));
    if (!ready) a.removeAttribute('href');
  }
  if (!ready) return;
  const safe = jobName(job).replace(/[^\w.-]+/g, '_');
  png.href = withQuery(jobLinks(job).png, toneParams());
  png.download = `${safe}.png`;
  exr.href = jobLinks(job).exr;
  exr.download = `${safe}.exr`;
}

/** With a token, a plain link cannot authenticate: fetch the file and save the blob. */
export async function download(ev) {
  const a = ev.currentTarget;
  if (a.getAttribute('aria-disabled') === 'true') {
    ev.preventDefault();
    return;
  }
  if (!getToken()) return; // the browser follows the link
  ev.preventDefault();
  try {
    const res = await fetch(a.href, { headers: authHeaders(), cache: 'no-store' });
    if (!res.ok) throw await toApiError(res);
    const url = URL.createObjectURL(await res.blob());
    const tmp = el('a', { href: url, download: a.download });
    document.body.append(tmp);
    tmp.click();
    tmp.remove();
    setTimeout(() => URL.revokeObjectURL(url), 10000);
  } catch (err) {
    $('view-message').textContent = `Download failed: ${err.describe ? err.describe() : err.message}`;
  }
}

// ---------------------------------------------------------------------------------------------
// Exposure and tonemap
// ---------------------------------------------------------------------------------------------

export function renderTone() {
  const e = state.tone.exposure;
  $('exposure').value = String(e);
  $('exposure-value').textContent = `${e >= 0 ? '+' : '−'}${Math.abs(e).toFixed(1)} EV`;
  $('tonemap').value = state.tone.tonemap;
}

export const applyTone = debounce(() => {
  try {
    localStorage.setItem(STORE.tone, JSON.stringify(state.tone));
  } catch {
    /* storage unavailable */
  }
  const job = state.jobs.get(state.selected);
  if (job && $('view-image').getAttribute('src')) {
    const spp = $('view-image').dataset.spp ?? '';
    viewSlot.load(pngUrl(job, state.snapshotUrl), { spp, job: jobId(job) });
  }
  updateDownloads();
  emit('tone-changed');
}, 150);

export function initTone() {
  try {
    const saved = JSON.parse(localStorage.getItem(STORE.tone) || 'null');
    if (saved && Number.isFinite(saved.exposure)) state.tone.exposure = saved.exposure;
    if (saved && ['clamp', 'reinhard', 'aces'].includes(saved.tonemap)) state.tone.tonemap = saved.tonemap;
  } catch {
    /* ignore */
  }
  renderTone();
  $('exposure').addEventListener('input', () => {
    state.tone.exposure = Math.round(Number($('exposure').value) * 10) / 10;
    renderTone();
    applyTone();
  });
  $('exposure-reset').addEventListener('click', () => {
    state.tone.exposure = 0;
    renderTone();
    applyTone();
  });
  $('tonemap').addEventListener('change', () => {
    state.tone.tonemap = $('tonemap').value;
    applyTone();
  });
}
