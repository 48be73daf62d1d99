// candela web viewer: the new-render form (example, pasted JSON, uploaded scene + assets, scene
// folder archive; budget, seed, priority, resolution, reference job) and POST /api/jobs.

import { $, el } from './util.js';
import { api } from './api.js';
import { state, jobId } from './state.js';
import { refreshJobs, renderJobs, upsertJob } from './jobs.js';
import { selectJob } from './viewer.js';

// ---------------------------------------------------------------------------------------------
// Submit form
// ---------------------------------------------------------------------------------------------

export function sourceKind() {
  return document.querySelector('input[name="source"]:checked').value;
}

export function showSourcePane() {
  const kind = sourceKind();
  for (const pane of document.querySelectorAll('.source-pane')) pane.hidden = pane.dataset.source !== kind;
}

export async function loadScenes() {
  try {
    const res = await api('/api/scenes');
    const list = Array.isArray(res) ? res : (res && res.scenes) || [];
    state.scenes = list.map((s) => (typeof s === 'string' ? { name: s } : s));
  } catch (err) {
    state.scenes = [];
    if (err.status !== 401) showSubmitError(`Could not list the example scenes: ${err.describe()}`);
    return;
  }
  const sel = $('scene-name');
  const prev = sel.value || 'cornell';
  sel.replaceChildren(
    ...state.scenes.map((s) => el('option', { value: s.name, text: s.title ? `${s.name} — ${s.title}` : s.name })),
  );
  if (state.scenes.some((s) => s.name === prev)) sel.value = prev;
  describeScene();
}

/** The integrator list from GET /api/integrators (the server's registry): one option each, then
 * `auto` (a choice among the unbiased ones by a pilot, when the server offers it), the server's
 * default selected, and the chosen one's options described under the options field. */
export async function loadIntegrators() {
  let res;
  try {
    res = await api('/api/integrators');
  } catch (err) {
    if (err.status !== 401) showSubmitError(`Could not list the integrators: ${err.describe()}`);
    return;
  }
  state.integrators = (res && res.integrators) || [];
  state.autoEntry = (res && res.auto) || null;
  const sel = $('integrator');
  const prev = sel.value || res.default;
  const entries = [...state.integrators, ...(state.autoEntry ? [state.autoEntry] : [])];
  sel.replaceChildren(
    ...entries.map((i) => el('option', { value: i.name, text: `${i.name}: ${i.summary}` })),
  );
  if (entries.some((i) => i.name === prev)) sel.value = prev;
  describeIntegrator();
}

/** The chosen integrator's options, as a hint and as the options field's placeholder. */
export function describeIntegrator() {
  if (isAuto()) {
    $('integrator-desc').textContent = `Chooses among ${state.autoEntry.candidates.join(', ')}; no options or max depth.`;
    $('integrator-options').placeholder = 'no options';
    return;
  }
  const i = (state.integrators || []).find((x) => x.name === $('integrator').value);
  const fields = (i && i.options) || [];
  $('integrator-desc').textContent = fields.length
    ? `Options: ${fields.map((f) => `${f.name} (${f.kind}): ${f.help}`).join('; ')}`
    : '';
  const first = fields[0];
  $('integrator-options').placeholder = first ? `e.g. {"${first.name}": …}` : 'no options';
}

export function describeScene() {
  const s = state.scenes.find((x) => x.name === $('scene-name').value);
  const bits = [];
  if (s && s.width && s.height) bits.push(`${s.width}×${s.height}`);
  const r = (s && s.render) || {};
  if (r.integrator) bits.push(r.integrator);
  if (r.spp) bits.push(`${r.spp} spp`);
  const text = bits.length ? `Scene defaults: ${bits.join(' · ')}` : '';
  $('scene-desc').textContent = s && s.description ? `${s.description}${text ? ` (${text})` : ''}` : text;
}

export async function loadExampleJson() {
  const name = $('scene-name').value;
  const s = state.scenes.find((x) => x.name === name);
  try {
    let scene = s && s.scene;
    if (!scene) {
      const url = (s && (s.url || (s.links && (s.links.scene || s.links.self)))) || `/api/scenes/${encodeURIComponent(name)}`;
      scene = await api(url);
      if (scene && scene.scene) scene = scene.scene;
    }
    $('scene-json').value = JSON.stringify(scene, null, 2);
    clearSubmitError();
  } catch (err) {
    showSubmitError(`Could not load the scene "${name}": ${err.describe()}`);
  }
}

export function showSubmitError(text, field) {
  const p = $('submit-error');
  p.textContent = text;
  p.hidden = false;
  if (field) {
    field.setAttribute('aria-invalid', 'true');
    field.focus();
  }
}

export function clearSubmitError() {
  $('submit-error').hidden = true;
  $('submit-error').textContent = '';
  for (const f of document.querySelectorAll('[aria-invalid="true"]')) f.removeAttribute('aria-invalid');
}

/** Reads an optional integer input; throws a message naming the field when invalid. */
export function readInt(input, label, { min = -Infinity, optional = false } = {}) {
  const raw = input.value.trim();
  if (raw === '') {
    if (optional) return undefined;
    throw { field: input, message: `${label} is required.` };
  }
  const v = Number(raw);
  if (!Number.isInteger(v) || v < min) throw { field: input, message: `${label} must be an integer ≥ ${min}.` };
  return v;
}

/** The integrator's options: a JSON object typed in the field (empty: none). The server checks
 *  the fields and names an unknown one. */
function readOptions(input) {
  const text = input.value.trim();
  if (!text) return {};
  let v;
  try {
    v = JSON.parse(text);
  } catch (e) {
    throw { field: input, message: `Integrator options: not JSON (${e.message}).` };
  }
  if (v === null || typeof v !== 'object' || Array.isArray(v)) {
    throw { field: input, message: 'Integrator options must be a JSON object, e.g. {"resolution": 128}.' };
  }
  return v;
}

/** Whether the form's integrator is `auto` (sent as the plain name: it takes no options). */
function isAuto() {
  return Boolean(state.autoEntry) && $('integrator').value === state.autoEntry.name;
}

/** The job settings from the form (everything but the scene). */
export function readSettings() {
  const settings = {};
  const name = $('job-name').value.trim();
  if (name) settings.name = name;
  const options = readOptions($('integrator-options'));
  const depth = readInt($('max-depth'), 'Max depth', { min: -1, optional: true });
  if (isAuto()) {
    if (Object.keys(options).length) throw { field: $('integrator-options'), message: 'auto takes no integrator options.' };
    if (depth !== undefined) throw { field: $('max-depth'), message: 'auto takes no max depth.' };
    settings.integrator = state.autoEntry.name;
  } else {
    const integrator = { ...options, type: $('integrator').value };
    if (depth !== undefined) integrator.max_depth = depth;
    settings.integrator = integrator;
  }

  const budgetInput = $('budget-value');
  const byTime = document.querySelector('input[name="budget"]:checked').value === 'time';
  if (byTime) {
    const t = Number(budgetInput.value);
    if (!(t > 0)) throw { field: budgetInput, message: 'The time budget must be a positive number of seconds.' };
    settings.time_s = t;
  } else {
    settings.spp = readInt(budgetInput, 'Samples per pixel', { min: 1 });
  }
  settings.seed = readInt($('seed'), 'Seed', { min: 0, optional: true }) ?? 0;
  const priority = readInt($('priority'), 'Priority', { min: 1, optional: true });
  if (priority !== undefined) settings.priority = priority;
  const w = readInt($('width'), 'Width', { min: 1, optional: true });
  const h = readInt($('height'), 'Height', { min: 1, optional: true });
  if ((w === undefined) !== (h === undefined)) {
    throw { field: w === undefined ? $('width') : $('height'), message: 'Give both width and height, or neither.' };
  }
  if (w !== undefined) {
    settings.width = w;
    settings.height = h;
  }
  const ref = $('reference-job').value;
  if (ref) settings.reference = { job: Number(ref) };
  return settings;
}

export function parseSceneText(text, what) {
  try {
    return JSON.parse(text);
  } catch (err) {
    throw { message: `${what} is not valid JSON: ${err.message}` };
  }
}

/** Every string in a scene that looks like a relative file path (mesh, texture, env map). */
export function sceneFileRefs(scene) {
  const out = [];
  const walk = (v) => {
    if (typeof v === 'string') {
      if (/\.[A-Za-z0-9]{2,4}$/.test(v) && !v.startsWith('/') && !v.includes('..')) out.push(v);
    } else if (v && typeof v === 'object') {
      for (const x of Object.values(v)) walk(x);
    }
  };
  walk(scene);
  return out;
}

/** Builds the POST /api/jobs request: JSON for named/pasted scenes, multipart for uploads. */
export async function buildJobRequest() {
  const settings = readSettings();
  switch (sourceKind()) {
    case 'example':
      return { json: { scene_name: $('scene-name').value, ...settings } };
    case 'paste': {
      const ta = $('scene-json');
      if (!ta.value.trim()) throw { field: ta, message: 'Paste a scene JSON first.' };
      try {
        return { json: { scene: parseSceneText(ta.value, 'The scene'), ...settings } };
      } catch (e) {
        throw { field: ta, message: e.message };
      }
    }
    case 'file': {
      const input = $('scene-file');
      const file = input.files[0];
      if (!file) throw { field: input, message: 'Choose a scene file.' };
      if (!/\.json$/i.test(file.name)) {
        // Another format (docs/import.md): the server imports it; its files go by their names.
        const form = new FormData();
        form.append('job', new Blob([JSON.stringify(settings)], { type: 'application/json' }), 'job.json');
        form.append('scene', file, file.name);
        for (const a of $('asset-files').files) form.append(a.name, a, a.name);
        return { body: form };
      }
      const text = await file.text();
      parseSceneText(text, file.name); // fail early with a clear message
      const assets = [...$('asset-files').files];
      if (!assets.length) return { json: { scene: JSON.parse(text), ...settings } };
      // One part per asset, named by the path the scene uses for it (multipart upload).
      const refs = sceneFileRefs(JSON.parse(text));
      const form = new FormData();
      form.append('job', new Blob([JSON.stringify(settings)], { type: 'application/json' }), 'job.json');
      form.append('scene', new Blob([text], { type: 'application/json' }), file.name);
      for (const a of assets) form.append(refs.find((r) => r === a.name || r.endsWith(`/${a.name}`)) || a.name, a, a.name);
      return { body: form };
    }
    case 'archive': {
      const input = $('archive-file');
      const file = input.files[0];
      if (!file) throw { field: input, message: 'Choose a .zip or .tar of the scene folder.' };
      const form = new FormData();
      form.append('job', new Blob([JSON.stringify(settings)], { type: 'application/json' }), 'job.json');
      form.append('archive', file, file.name);
      return { body: form };
    }
    default:
      throw { message: 'Pick a scene source.' };
  }
}

export async function submitJob(ev) {
  ev.preventDefault();
  clearSubmitError();
  const button = $('submit-button');
  let req;
  try {
    req = await buildJobRequest();
  } catch (e) {
    showSubmitError(e.message || String(e), e.field);
    return;
  }
  button.disabled = true;
  button.textContent = 'Submitting…';
  try {
    const job = await api('/api/jobs', { method: 'POST', ...req });
    upsertJob(job, true);
    renderJobs();
    selectJob(jobId(job));
    refreshJobs();
  } catch (err) {
    const code = err.code && err.status ? `${err.status} ${err.code}: ` : '';
    showSubmitError(`${code}${err.describe ? err.describe() : err.message}`);
  } finally {
    button.disabled = false;
    button.textContent = 'Render';
  }
}

export function initForm() {
  for (const r of document.querySelectorAll('input[name="source"]')) r.addEventListener('change', showSourcePane);
  showSourcePane();
  $('scene-name').addEventListener('change', describeScene);
  $('integrator').addEventListener('change', describeIntegrator);
  $('load-example-json').addEventListener('click', loadExampleJson);
  for (const r of document.querySelectorAll('input[name="budget"]')) {
    r.addEventListener('change', () => {
      const byTime = r.value === 'time' && r.checked;
      const input = $('budget-value');
      input.step = byTime ? 'any' : '1';
      input.min = byTime ? '0.1' : '1';
      input.value = byTime ? '10' : '64';
    });
  }
  $('submit-form').addEventListener('submit', submitJob);
  $('submit-form').addEventListener('input', (e) => e.target.removeAttribute('aria-invalid'));
}
