// candela web viewer: the job list (polled, keyed in-place row updates), per-job controls
// (pause/resume, cancel, delete, priority, compare as A/B) and the form's reference-job selector.

import { $, TERMINAL, el } from './util.js';
import { api, checkHealth, setServerStatus } from './api.js';
import {
  emit, state, jobBudgetText, jobFraction, jobId, jobIntegrator, jobLinks, jobName, jobProgress, jobResolution,
} from './state.js';

// ---------------------------------------------------------------------------------------------
// Job list
// ---------------------------------------------------------------------------------------------

export function upsertJob(job, front = false) {
  const id = jobId(job);
  if (!state.jobs.has(id)) {
    if (front) state.order.unshift(id);
    else state.order.push(id);
  }
  state.jobs.set(id, job);
}

let refreshTimer = 0;
let refreshing = false;
let refreshAgain = false;

/** Fetches the job list (coalesced: a call during a fetch runs once more right after it). */
export async function refreshJobs() {
  clearTimeout(refreshTimer);
  if (refreshing) {
    refreshAgain = true;
    return;
  }
  refreshing = true;
  refreshAgain = false;
  let active = false;
  try {
    const filter = $('state-filter').value;
    const res = await api(filter ? `/api/jobs?state=${encodeURIComponent(filter)}` : '/api/jobs');
    const list = Array.isArray(res) ? res : (res && res.jobs) || [];
    // Newest first: by creation time when given, else by id as the server lists them.
    const sorted = [...list].sort((a, b) => {
      const ta = Date.parse(a.created_at || '') || 0;
      const tb = Date.parse(b.created_at || '') || 0;
      return tb - ta;
    });
    state.jobs = new Map(sorted.map((j) => [jobId(j), j]));
    state.order = sorted.map(jobId);
    active = sorted.some((j) => !TERMINAL.has(j.state));
    if (state.unauthorized) {
      state.unauthorized = false;
      checkHealth();
    } else if ($('server-status').dataset.kind === 'bad') {
      checkHealth();
    }
    renderJobs();
    emit('jobs-refreshed');
  } catch (err) {
    if (err.status !== 401) setServerStatus(`Job list: ${err.describe()}`, 'bad');
  } finally {
    refreshing = false;
    const ms = refreshAgain ? 0 : document.hidden ? 10000 : active ? 1500 : 5000;
    refreshTimer = setTimeout(refreshJobs, ms);
  }
}

/** Keyed update of the job list: rows are created once and updated in place (focus survives). */
export function renderJobs() {
  const ul = $('job-list');
  const rows = new Map([...ul.children].map((li) => [li.dataset.id, li]));
  let prev = null;
  for (const id of state.order) {
    const job = state.jobs.get(id);
    let li = rows.get(id);
    if (!li) li = buildJobRow(id);
    rows.delete(id);
    updateJobRow(li, job);
    const want = prev ? prev.nextSibling : ul.firstChild;
    if (want !== li) ul.insertBefore(li, want);
    prev = li;
  }
  for (const li of rows.values()) li.remove();
  $('jobs-empty').hidden = state.order.length > 0;
  $('jobs-empty').textContent = $('state-filter').value ? 'No jobs in this state.' : 'No jobs yet.';
  renderReferenceOptions();
  emit('jobs-rendered');
}

/** The submit form's reference selector: every done job (keeps the current choice). */
export function renderReferenceOptions() {
  const sel = $('reference-job');
  const keep = sel.value;
  const done = state.order.filter((id) => (state.jobs.get(id) || {}).state === 'done');
  sel.replaceChildren(el('option', { value: '' }, 'none'),
    ...done.map((id) => el('option', { value: String(id) }, `#${id} ${jobName(state.jobs.get(id))} (${jobResolution(state.jobs.get(id))})`)));
  sel.value = done.map(String).includes(keep) ? keep : '';
}


/** Updates one row in place (progress events of the selected job). */
export function renderJobRow(id) {
  const li = $('job-list').querySelector(`li[data-id="${CSS.escape(id)}"]`);
  const job = state.jobs.get(id);
  if (li && job) updateJobRow(li, job);
}

export function buildJobRow(id) {
  const li = el('li', { class: 'job', 'data-id': id });
  const open = el('button', { class: 'job-open', type: 'button', onclick: () => emit('open-job', id) },
    el('span', { class: 'job-name' }), el('span', { class: 'job-meta' }));
  const badge = el('span', { class: 'badge job-state' });
  const progress = el('progress', { class: 'job-progress', max: '1' });
  const budget = el('span', { class: 'job-budget' });
  const prioId = `prio-${id}`;
  const prio = el('input', { id: prioId, class: 'job-priority', type: 'number', min: '1', max: '100', step: '1' });
  prio.addEventListener('change', () => setPriority(id, prio));
  prio.addEventListener('keydown', (e) => {
    if (e.key === 'Enter') prio.blur();
  });
  const pause = el('button', { class: 'job-pause secondary small', type: 'button', onclick: () => pauseResume(id) });
  const cancel = el('button', { class: 'job-cancel danger small', type: 'button', onclick: () => cancelJob(id) });
  cancel.textContent = 'Cancel';
  const del = el('button', { class: 'job-delete danger small', type: 'button', hidden: '', onclick: () => deleteJob(id) });
  del.textContent = 'Delete';
  const setA = el('button', { class: 'job-set-a secondary small', type: 'button', text: 'A', onclick: () => emit('set-ab', 'a', id) });
  const setB = el('button', { class: 'job-set-b secondary small', type: 'button', text: 'B', onclick: () => emit('set-ab', 'b', id) });
  li.append(
    el('div', { class: 'job-top' }, open, badge),
    el('div', { class: 'job-mid' }, progress, budget),
    el('div', { class: 'job-actions' },
      el('label', { class: 'job-prio-label', for: prioId, text: 'Priority' }), prio,
      pause, cancel, del,
      el('span', { class: 'job-ab', role: 'group', 'aria-label': 'Compare' }, setA, setB)),
    el('p', { class: 'job-error error', hidden: '' }),
  );
  return li;
}

export function updateJobRow(li, job) {
  const id = jobId(job);
  const name = jobName(job);
  const st = job.state || 'unknown';
  const q = (sel) => li.querySelector(sel);
  li.dataset.state = st;
  li.classList.toggle('selected', state.selected === id);
  if (state.selected === id) li.setAttribute('aria-current', 'true');
  else li.removeAttribute('aria-current');

  q('.job-name').textContent = name;
  const meta = [`#${id}`, jobIntegrator(job), jobResolution(job)].filter(Boolean).join(' · ');
  q('.job-meta').textContent = meta;
  q('.job-open').setAttribute('aria-label', `View ${name} (${st})`);
  const badge = q('.job-state');
  badge.textContent = st;
  badge.className = `badge job-state state-${st}`;

  const progress = state.selected === id && state.live ? { ...jobProgress(job), ...state.live } : jobProgress(job);
  const frac = jobFraction(job, progress);
  const bar = q('.job-progress');
  if (frac == null) bar.removeAttribute('value');
  else bar.value = frac;
  bar.setAttribute('aria-label', `Progress of ${name}`);
  q('.job-budget').textContent = jobBudgetText(job, progress);

  const prio = q('.job-priority');
  if (document.activeElement !== prio) prio.value = job.priority ?? '';
  prio.setAttribute('aria-label', `Priority of ${name}`);
  prio.disabled = TERMINAL.has(st);

  const pause = q('.job-pause');
  pause.textContent = st === 'paused' ? 'Resume' : 'Pause';
  pause.setAttribute('aria-label', `${st === 'paused' ? 'Resume' : 'Pause'} ${name}`);
  pause.disabled = !(st === 'paused' || st === 'running' || st === 'queued');
  const cancel = q('.job-cancel');
  cancel.setAttribute('aria-label', `Cancel ${name}`);
  cancel.disabled = TERMINAL.has(st);
  const del = q('.job-delete');
  del.setAttribute('aria-label', `Delete ${name}`);
  del.hidden = !TERMINAL.has(st); // only finished jobs can be deleted (the server says 409 otherwise)
  q('.job-set-a').setAttribute('aria-label', `Compare ${name} as A`);
  q('.job-set-b').setAttribute('aria-label', `Compare ${name} as B`);
  q('.job-set-a').setAttribute('aria-pressed', String(state.ab.a === id));
  q('.job-set-b').setAttribute('aria-pressed', String(state.ab.b === id));

  const err = q('.job-error');
  const message = job.error && (job.error.message || job.error);
  // A failed job's error, or why the server holds a paused job (a full disk).
  const note = st === 'failed' && message ? String(message) : st === 'paused' && job.hold ? `Held: ${job.hold}` : '';
  err.hidden = !note;
  err.textContent = note;
}

export async function jobAction(id, fn) {
  const li = $('job-list').querySelector(`li[data-id="${CSS.escape(id)}"]`);
  const errP = li && li.querySelector('.job-error');
  try {
    const job = await fn();
    if (job && job.id != null) upsertJob(job);
    if (errP) errP.hidden = true;
    renderJobs();
    if (job && job.id != null) emit('job-changed', job);
  } catch (err) {
    if (errP) {
      errP.textContent = err.describe ? err.describe() : String(err);
      errP.hidden = false;
    }
  }
  refreshJobs();
}

export function pauseResume(id) {
  const job = state.jobs.get(id);
  const verb = job && job.state === 'paused' ? 'resume' : 'pause';
  return jobAction(id, () => api(`${jobLinks(job).self}/${verb}`, { method: 'POST' }));
}

export function cancelJob(id) {
  const job = state.jobs.get(id);
  return jobAction(id, () => api(`${jobLinks(job).self}/cancel`, { method: 'POST' }));
}

/** Deletes a finished job with its image and events (DELETE /api/jobs/{id}), after asking. */
export function deleteJob(id) {
  const job = state.jobs.get(id);
  if (!window.confirm(`Delete ${jobName(job)} with its image and events? This cannot be undone.`)) return null;
  return jobAction(id, async () => {
    await api(jobLinks(job).self, { method: 'DELETE' });
    state.jobs.delete(id);
    state.order = state.order.filter((j) => j !== id);
    refreshJobs();
    return null;
  });
}

export function setPriority(id, input) {
  const job = state.jobs.get(id);
  const p = Number(input.value);
  if (!Number.isInteger(p) || p < 1) {
    input.value = job.priority ?? '';
    return;
  }
  return jobAction(id, () => api(jobLinks(job).self, { method: 'PATCH', json: { priority: p } }));
}
