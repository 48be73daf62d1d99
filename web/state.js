// candela web viewer: the application state and the job field accessors (tolerant of small
// differences in the server's JSON).

import { fmtDuration } from './util.js';

// ---------------------------------------------------------------------------------------------
// Application state
// ---------------------------------------------------------------------------------------------

export const state = {
  jobs: new Map(), // id -> job (as last listed)
  order: [], // ids, newest first
  scenes: [], // built-in example scenes
  integrators: [], // the server's integrator registry (GET /api/integrators)
  autoEntry: null, // `auto` as GET /api/integrators describes it (name, summary, candidates)
  selected: null, // id of the job in the viewer
  stream: null, // EventStream of the selected job
  live: null, // latest progress of the selected job from SSE
  auto: null, // the selected job's `auto` choice from SSE ({choice, pilots})
  snapshotUrl: null, // URL of the selected job's latest snapshot event
  tone: { exposure: 0, tonemap: 'clamp' },
  ab: { a: '', b: '', pos: 50 },
  unauthorized: false,
};

// ---------------------------------------------------------------------------------------------
// Events between modules
// ---------------------------------------------------------------------------------------------
// Modules import in one direction (jobs → viewer → ab → form → app); a lower module tells the
// higher ones what happened through these named events, which they subscribe to in their init:
//   'jobs-rendered'         the job list was redrawn (ab: refresh the A/B selectors)
//   'jobs-refreshed'        the list was fetched again (viewer: sync the selected job; ab: images)
//   'open-job' (id)         a row asks to be shown in the viewer (viewer)
//   'set-ab' (side, id)     a row asks to be compared as A or B (ab)
//   'job-changed' (job)     a job was updated by a control in the list (viewer: its header)
//   'job-selected' (id)     the viewer shows another job (ab: switch to the single view)
//   'tone-changed'          exposure or tonemap changed (ab: reload its images)

const listeners = new Map();

/** Calls `fn(...args)` whenever `name` is emitted. */
export function on(name, fn) {
  if (!listeners.has(name)) listeners.set(name, []);
  listeners.get(name).push(fn);
}

/** Tells every subscriber of `name`. */
export function emit(name, ...args) {
  for (const fn of listeners.get(name) || []) fn(...args);
}

// ---------------------------------------------------------------------------------------------
// Job field accessors (tolerant of small differences in the server's JSON)
// ---------------------------------------------------------------------------------------------

export const jobId = (j) => String(j.id);
export const jobName = (j) => j.name || `job ${j.id}`;
export const jobSettings = (j) => j.settings || {};
export const jobProgress = (j) => j.progress || {};
/** Progress merged with the final statistics of a finished job (msamples_per_s, rays_per_s). */
export const jobNumbers = (j) => ({ ...jobProgress(j), ...(j.stats || {}) });
/** Whether the job names a reference (its progress events then carry error metrics). */
export const jobHasReference = (j) => Boolean(jobSettings(j).reference);
export const jobSpp = (j) => jobProgress(j).spp ?? 0;
/** Seconds rendered so far (SSE progress says elapsed_s, the job JSON time_s). */
export const elapsedOf = (p) => p.elapsed_s ?? p.time_s;

export function jobLinks(j) {
  const base = `/api/jobs/${encodeURIComponent(jobId(j))}`;
  const l = j.links || {};
  return {
    self: l.self || base,
    events: l.events || `${base}/events`,
    png: l['image.png'] || l.png || `${base}/image.png`,
    exr: l['image.exr'] || l.exr || `${base}/image.exr`,
  };
}

/** The job's integrator; an `auto` job's is "auto", with its choice once made ("auto: nee"). */
export function jobIntegrator(j) {
  if (jobSettings(j).auto) return j.stats && j.stats.integrator ? `auto: ${j.stats.integrator}` : 'auto';
  const i = jobSettings(j).integrator;
  return typeof i === 'string' ? i : (i && i.type) || '';
}

/** Fraction done in [0, 1], or null when unknown. */
export function jobFraction(j, progress = jobProgress(j)) {
  if (j.state === 'done') return 1;
  const s = jobSettings(j);
  const spp = progress.spp ?? 0;
  if (s.spp) return Math.min(1, spp / s.spp);
  if (s.time_s) return Math.min(1, (elapsedOf(progress) ?? 0) / s.time_s);
  return progress.fraction ?? null;
}

export function jobBudgetText(j, progress = jobProgress(j)) {
  const s = jobSettings(j);
  const spp = progress.spp ?? 0;
  if (s.spp) return `${spp} / ${s.spp} spp`;
  if (s.time_s) return `${spp} spp · ${fmtDuration(elapsedOf(progress) ?? 0)} / ${fmtDuration(s.time_s)}`;
  return `${spp} spp`;
}

export function jobResolution(j) {
  const s = jobSettings(j);
  return s.width && s.height ? `${s.width}×${s.height}` : '';
}
