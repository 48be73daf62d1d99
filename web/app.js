// candela web viewer: talks to the render server's JSON API (/api/...), streams job events over
// SSE (parsed from fetch, so a bearer token can be sent), shows the refining image with exposure
// and tonemap, manages the job queue and compares two jobs' images with a draggable divider.
// Plain modern JavaScript, no dependencies, no build step.

// ---------------------------------------------------------------------------------------------
// Small helpers
// ---------------------------------------------------------------------------------------------

const $ = (id) => document.getElementById(id);
const TERMINAL = new Set(['done', 'failed', 'canceled']);
const STORE = {
  token: 'candela.token',
  tone: 'candela.tone',
};

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

function debounce(fn, ms) {
  let t = 0;
  return (...args) => {
    clearTimeout(t);
    t = setTimeout(() => fn(...args), ms);
  };
}

function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === 'class') node.className = v;
    else if (k === 'text') node.textContent = v;
    else if (k.startsWith('on')) node.addEventListener(k.slice(2), v);
    else node.setAttribute(k, v);
  }
  for (const c of children) node.append(c);
  return node;
}

function fmtDuration(s) {
  if (s == null || !Number.isFinite(s) || s < 0) return '—';
  if (s < 59.5) return `${s.toFixed(s < 9.95 ? 1 : 0)} s`;
  const total = Math.round(s);
  const m = Math.floor(total / 60);
  if (m < 60) return `${m} min ${String(total - m * 60).padStart(2, '0')} s`;
  const h = Math.floor(m / 60);
  return `${h} h ${String(m - h * 60).padStart(2, '0')} min`;
}

function fmtSi(x) {
  if (x == null || !Number.isFinite(x)) return '—';
  const units = [[1e12, 'T'], [1e9, 'G'], [1e6, 'M'], [1e3, 'k']];
  for (const [f, u] of units) if (Math.abs(x) >= f) return `${(x / f).toPrecision(3)} ${u}`;
  return x.toPrecision(3);
}

function fmtNum(x, digits = 3) {
  if (x == null || !Number.isFinite(x)) return '—';
  return x >= 100 ? x.toFixed(0) : x.toPrecision(digits);
}

// ---------------------------------------------------------------------------------------------
// API access (bearer token from local storage; errors are {"error": {code, message, path?}})
// ---------------------------------------------------------------------------------------------

class ApiError extends Error {
  constructor(status, code, message, path) {
    super(message);
    this.status = status;
    this.code = code;
    this.path = path;
  }
  /** One line for the user: "message (at path)". */
  describe() {
    const where = this.path ? ` (at ${this.path})` : '';
    return `${this.message}${where}`;
  }
}

function getToken() {
  try {
    return localStorage.getItem(STORE.token) || '';
  } catch {
    return '';
  }
}

function authHeaders() {
  const t = getToken();
  return t ? { Authorization: `Bearer ${t}` } : {};
}

async function toApiError(res) {
  let body = null;
  try {
    body = await res.json();
  } catch {
    /* not JSON */
  }
  const e = body && body.error ? body.error : {};
  const message = e.message || `${res.status} ${res.statusText || 'error'}`;
  return new ApiError(res.status, e.code || String(res.status), message, e.path);
}

/** fetch() against the API with the token; returns parsed JSON (or null for 204). */
async function api(path, { method = 'GET', json, body, signal } = {}) {
  const headers = { Accept: 'application/json', ...authHeaders() };
  if (json !== undefined) {
    headers['Content-Type'] = 'application/json';
    body = JSON.stringify(json);
  }
  let res;
  try {
    res = await fetch(path, { method, headers, body, signal, cache: 'no-store' });
  } catch (err) {
    if (err.name === 'AbortError') throw err;
    throw new ApiError(0, 'network', 'The server cannot be reached.');
  }
  if (res.status === 401) noteUnauthorized();
  if (!res.ok) throw await toApiError(res);
  if (res.status === 204) return null;
  const text = await res.text();
  return text ? JSON.parse(text) : null;
}

/** Adds/replaces query parameters on a same-origin URL and returns path + query. */
function withQuery(url, params) {
  const u = new URL(url, location.href);
  for (const [k, v] of Object.entries(params)) {
    if (v == null || v === '') u.searchParams.delete(k);
    else u.searchParams.set(k, String(v));
  }
  return u.origin === location.origin ? u.pathname + u.search : u.href;
}

// ---------------------------------------------------------------------------------------------
// Job field accessors (tolerant of small differences in the server's JSON)
// ---------------------------------------------------------------------------------------------

const jobId = (j) => String(j.id);
const jobName = (j) => j.name || `job ${j.id}`;
const jobSettings = (j) => j.settings || {};
const jobProgress = (j) => j.progress || {};
/** Progress merged with the final statistics of a finished job (msamples_per_s, rays_per_s). */
const jobNumbers = (j) => ({ ...jobProgress(j), ...(j.stats || {}) });
const jobSpp = (j) => jobProgress(j).spp ?? 0;
/** Seconds rendered so far (SSE progress says elapsed_s, the job JSON time_s). */
const elapsedOf = (p) => p.elapsed_s ?? p.time_s;

function jobLinks(j) {
  const base = `/api/jobs/${encodeURIComponent(jobId(j))}`;
  const l = j.links || {};
  return {
    self: l.self || base,
    events: l.events || `${base}/events`,
    png: l['image.png'] || l.png || `${base}/image.png`,
    exr: l['image.exr'] || l.exr || `${base}/image.exr`,
  };
}

function jobIntegrator(j) {
  const i = jobSettings(j).integrator;
  return typeof i === 'string' ? i : (i && i.type) || '';
}

/** Fraction done in [0, 1], or null when unknown. */
function jobFraction(j, progress = jobProgress(j)) {
  if (j.state === 'done') return 1;
  const s = jobSettings(j);
  const spp = progress.spp ?? 0;
  if (s.spp) return Math.min(1, spp / s.spp);
  if (s.time_s) return Math.min(1, (elapsedOf(progress) ?? 0) / s.time_s);
  return progress.fraction ?? null;
}

function jobBudgetText(j, progress = jobProgress(j)) {
  const s = jobSettings(j);
  const spp = progress.spp ?? 0;
  if (s.spp) return `${spp} / ${s.spp} spp`;
  if (s.time_s) return `${spp} spp · ${fmtDuration(elapsedOf(progress) ?? 0)} / ${fmtDuration(s.time_s)}`;
  return `${spp} spp`;
}

function jobResolution(j) {
  const s = jobSettings(j);
  return s.width && s.height ? `${s.width}×${s.height}` : '';
}

// ---------------------------------------------------------------------------------------------
// Server-sent events over fetch: same wire format as EventSource, but it can send the
// Authorization header, reconnects with Last-Event-ID, and has no clash with a custom "error"
// event type.
// ---------------------------------------------------------------------------------------------

class EventStream {
  /** handlers: {event name: fn(data, id)}; onStatus(text) for connection state. */
  constructor(url, handlers, onStatus = () => {}) {
    this.url = url;
    this.handlers = handlers;
    this.onStatus = onStatus;
    this.lastId = null;
    this.retryMs = 1000;
    this.closed = false;
    this.ctrl = new AbortController();
    this.run();
  }

  close() {
    this.closed = true;
    this.ctrl.abort();
  }

  async run() {
    let failures = 0;
    while (!this.closed) {
      try {
        const headers = { Accept: 'text/event-stream', ...authHeaders() };
        if (this.lastId != null) headers['Last-Event-ID'] = this.lastId;
        const res = await fetch(this.url, { headers, signal: this.ctrl.signal, cache: 'no-store' });
        if (res.status === 401) noteUnauthorized();
        if (!res.ok) {
          const err = await toApiError(res);
          // 4xx will not get better by retrying (except 408/429).
          if (res.status >= 400 && res.status < 500 && res.status !== 408 && res.status !== 429) {
            this.onStatus(`Live updates unavailable: ${err.describe()}`);
            return;
          }
          throw err;
        }
        failures = 0;
        this.onStatus('');
        await this.consume(res.body);
      } catch (err) {
        if (this.closed || err.name === 'AbortError') return;
        failures++;
        this.onStatus('Live updates interrupted; reconnecting…');
      }
      if (this.closed) return;
      await sleep(Math.min(this.retryMs * 2 ** Math.min(failures, 4), 15000));
    }
  }

  async consume(body) {
    const reader = body.pipeThrough(new TextDecoderStream()).getReader();
    let buf = '';
    let event = '';
    let data = [];
    let id = null;
    for (;;) {
      const { value, done } = await reader.read();
      if (done) return;
      buf += value;
      // Process complete lines; keep the (possibly partial) last one.
      const lines = buf.split(/\r\n|\r|\n/);
      buf = lines.pop();
      for (const line of lines) {
        if (line === '') {
          if (id != null) this.lastId = id;
          if (data.length) this.dispatch(event || 'message', data.join('\n'));
          event = '';
          data = [];
          id = null;
          if (this.closed) return;
          continue;
        }
        if (line.startsWith(':')) continue; // comment / keep-alive
        const colon = line.indexOf(':');
        const field = colon < 0 ? line : line.slice(0, colon);
        let val = colon < 0 ? '' : line.slice(colon + 1);
        if (val.startsWith(' ')) val = val.slice(1);
        if (field === 'event') event = val;
        else if (field === 'data') data.push(val);
        else if (field === 'id') id = val;
        else if (field === 'retry' && /^\d+$/.test(val)) this.retryMs = Number(val);
      }
    }
  }

  dispatch(event, raw) {
    const fn = this.handlers[event];
    if (!fn) return;
    let data = raw;
    try {
      data = JSON.parse(raw);
    } catch {
      /* plain text payload */
    }
    try {
      fn(data);
    } catch (err) {
      console.error(`candela: handling SSE "${event}" failed`, err);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Image loading: PNGs are fetched as blobs (so the token can be sent), requests for one <img>
// coalesce (only the newest pending request runs after the one in flight), and the element
// swaps to the new image only once it has decoded, so it never flickers.
// ---------------------------------------------------------------------------------------------

class ImageSlot {
  constructor(img, onLoad = () => {}, onError = () => {}) {
    this.img = img;
    this.onLoad = onLoad;
    this.onError = onError;
    this.busy = false;
    this.pending = null;
    this.objectUrl = null;
    this.generation = 0;
  }

  /** Requests `url`; meta is written to data-* attributes when it shows. */
  load(url, meta = {}) {
    this.pending = { url, meta, generation: this.generation };
    if (!this.busy) this.pump();
  }

  /** Forgets what is shown and anything pending (e.g. another job was selected). */
  reset() {
    this.generation++;
    this.pending = null;
    if (this.objectUrl) URL.revokeObjectURL(this.objectUrl);
    this.objectUrl = null;
    this.img.removeAttribute('src');
    for (const k of Object.keys(this.img.dataset)) delete this.img.dataset[k];
  }

  async pump() {
    this.busy = true;
    while (this.pending) {
      const { url, meta, generation } = this.pending;
      this.pending = null;
      try {
        const res = await fetch(url, { headers: authHeaders(), cache: 'no-store' });
        if (res.status === 401) noteUnauthorized();
        if (!res.ok) throw await toApiError(res);
        const blob = await res.blob();
        const objectUrl = URL.createObjectURL(blob);
        const probe = new Image();
        probe.src = objectUrl;
        await probe.decode();
        if (generation !== this.generation) {
          URL.revokeObjectURL(objectUrl);
          continue;
        }
        const old = this.objectUrl;
        this.objectUrl = objectUrl;
        for (const [k, v] of Object.entries(meta)) this.img.dataset[k] = String(v);
        this.img.dataset.url = url;
        this.img.dataset.updates = String(Number(this.img.dataset.updates || 0) + 1);
        this.img.src = objectUrl;
        if (old) URL.revokeObjectURL(old);
        this.onLoad(probe.naturalWidth, probe.naturalHeight);
      } catch (err) {
        if (generation === this.generation) this.onError(err);
      }
    }
    this.busy = false;
  }
}

/** Height an image may take: the window less room for the toolbar and statistics (not
 *  dependent on the scroll position, so the layout is stable). */
function availHeight() {
  return Math.max(240, Math.min(window.innerHeight - 260, 1400));
}

/** Sizes an image box to fit `avail`: integer upscaling (crisp pixels) or smooth downscaling. */
function fitBox(natW, natH, availW, availH) {
  if (!natW || !natH || availW <= 0 || availH <= 0) return { w: natW, h: natH, pixelated: false };
  const s = Math.min(availW / natW, availH / natH);
  const scale = s >= 1 ? Math.max(1, Math.floor(s)) : s;
  return { w: Math.round(natW * scale), h: Math.round(natH * scale), pixelated: scale > 1 };
}

// ---------------------------------------------------------------------------------------------
// Application state
// ---------------------------------------------------------------------------------------------

const state = {
  jobs: new Map(), // id -> job (as last listed)
  order: [], // ids, newest first
  scenes: [], // built-in example scenes
  selected: null, // id of the job in the viewer
  stream: null, // EventStream of the selected job
  live: null, // latest progress of the selected job from SSE
  snapshotUrl: null, // URL of the selected job's latest snapshot event
  metricPoints: [], // [elapsed_s, rel_mse] of the selected job's progress metrics
  tone: { exposure: 0, tonemap: 'clamp' },
  ab: { a: '', b: '', pos: 50 },
  unauthorized: false,
};

// ---------------------------------------------------------------------------------------------
// Token box and server status
// ---------------------------------------------------------------------------------------------

function noteUnauthorized() {
  if (state.unauthorized) return;
  state.unauthorized = true;
  setServerStatus(getToken() ? 'The access token was refused.' : 'This server needs an access token.', 'bad');
  $('token-box').open = true;
}

function setServerStatus(text, kind = '') {
  const s = $('server-status');
  s.textContent = text;
  s.dataset.kind = kind;
}

function renderTokenState() {
  $('token-state').textContent = getToken() ? '(set)' : '(none)';
}

function initToken() {
  renderTokenState();
  $('token-form').addEventListener('submit', (ev) => {
    ev.preventDefault();
    const t = $('token-input').value.trim();
    try {
      if (t) localStorage.setItem(STORE.token, t);
    } catch {
      /* storage unavailable */
    }
    $('token-input').value = '';
    afterTokenChange();
  });
  $('token-clear').addEventListener('click', () => {
    try {
      localStorage.removeItem(STORE.token);
    } catch {
      /* storage unavailable */
    }
    afterTokenChange();
  });
}

function afterTokenChange() {
  state.unauthorized = false;
  renderTokenState();
  $('token-box').open = false;
  checkHealth();
  loadScenes();
  refreshJobs();
  if (state.selected) selectJob(state.selected, { force: true });
}

async function checkHealth() {
  try {
    const h = await api('/api/health');
    // Health is open even when the API needs a token; it says whether one is required.
    if (h && h.auth && !getToken()) {
      noteUnauthorized();
      return;
    }
    if (state.unauthorized) return; // the API refused the token: keep saying so
    const bits = ['Connected'];
    const gpu = (h && h.gpu) || {};
    const dev = gpu.device || (h && h.device);
    if (dev) bits.push(typeof dev === 'string' ? dev : dev.name || '');
    if (gpu.state && gpu.state !== 'ready') bits.push(`GPU ${gpu.state}${gpu.error ? `: ${gpu.error}` : ''}`);
    if (h && h.version) bits.push(`candela ${h.version}`);
    setServerStatus(bits.filter(Boolean).join(' · '), h && h.status && h.status !== 'ok' ? 'warn' : 'ok');
  } catch (err) {
    if (err.status === 401) return; // noteUnauthorized said it
    if (err.status === 404) setServerStatus('Connected', 'ok');
    else setServerStatus(`Server: ${err.describe()}`, 'bad');
  }
}

// ---------------------------------------------------------------------------------------------
// Submit form
// ---------------------------------------------------------------------------------------------

function sourceKind() {
  return document.querySelector('input[name="source"]:checked').value;
}

function showSourcePane() {
  const kind = sourceKind();
  for (const pane of document.querySelectorAll('.source-pane')) pane.hidden = pane.dataset.source !== kind;
}

async function loadScenes() {
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

function describeScene() {
  const s = state.scenes.find((x) => x.name === $('scene-name').value);
  const bits = [];
  if (s && s.width && s.height) bits.push(`${s.width}×${s.height}`);
  const r = (s && s.render) || {};
  if (r.integrator) bits.push(r.integrator);
  if (r.spp) bits.push(`${r.spp} spp`);
  const text = bits.length ? `Scene defaults: ${bits.join(' · ')}` : '';
  $('scene-desc').textContent = s && s.description ? `${s.description}${text ? ` (${text})` : ''}` : text;
}

async function loadExampleJson() {
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

function showSubmitError(text, field) {
  const p = $('submit-error');
  p.textContent = text;
  p.hidden = false;
  if (field) {
    field.setAttribute('aria-invalid', 'true');
    field.focus();
  }
}

function clearSubmitError() {
  $('submit-error').hidden = true;
  $('submit-error').textContent = '';
  for (const f of document.querySelectorAll('[aria-invalid="true"]')) f.removeAttribute('aria-invalid');
}

/** Reads an optional integer input; throws a message naming the field when invalid. */
function readInt(input, label, { min = -Infinity, optional = false } = {}) {
  const raw = input.value.trim();
  if (raw === '') {
    if (optional) return undefined;
    throw { field: input, message: `${label} is required.` };
  }
  const v = Number(raw);
  if (!Number.isInteger(v) || v < min) throw { field: input, message: `${label} must be an integer ≥ ${min}.` };
  return v;
}

/** The job settings from the form (everything but the scene). */
function readSettings() {
  const settings = {};
  const name = $('job-name').value.trim();
  if (name) settings.name = name;
  const integrator = { type: $('integrator').value };
  const depth = readInt($('max-depth'), 'Max depth', { min: -1, optional: true });
  if (depth !== undefined) integrator.max_depth = depth;
  settings.integrator = integrator;

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

function parseSceneText(text, what) {
  try {
    return JSON.parse(text);
  } catch (err) {
    throw { message: `${what} is not valid JSON: ${err.message}` };
  }
}

/** Every string in a scene that looks like a relative file path (mesh, texture, env map). */
function sceneFileRefs(scene) {
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
async function buildJobRequest() {
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

async function submitJob(ev) {
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

function initForm() {
  for (const r of document.querySelectorAll('input[name="source"]')) r.addEventListener('change', showSourcePane);
  showSourcePane();
  $('scene-name').addEventListener('change', describeScene);
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

// ---------------------------------------------------------------------------------------------
// Job list
// ---------------------------------------------------------------------------------------------

function upsertJob(job, front = false) {
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
async function refreshJobs() {
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
    syncSelectedFromList();
    refreshAbImages();
  } catch (err) {
    if (err.status !== 401) setServerStatus(`Job list: ${err.describe()}`, 'bad');
  } finally {
    refreshing = false;
    const ms = refreshAgain ? 0 : document.hidden ? 10000 : active ? 1500 : 5000;
    refreshTimer = setTimeout(refreshJobs, ms);
  }
}

/** Keyed update of the job list: rows are created once and updated in place (focus survives). */
function renderJobs() {
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
  renderAbOptions();
  renderReferenceOptions();
}

/** The submit form's reference selector: every done job (keeps the current choice). */
function renderReferenceOptions() {
  const sel = $('reference-job');
  const keep = sel.value;
  const done = state.order.filter((id) => (state.jobs.get(id) || {}).state === 'done');
  sel.replaceChildren(el('option', { value: '' }, 'none'),
    ...done.map((id) => el('option', { value: String(id) }, `#${id} ${jobName(state.jobs.get(id))} (${jobResolution(state.jobs.get(id))})`)));
  sel.value = done.map(String).includes(keep) ? keep : '';
}

/** relMSE (log scale) against elapsed seconds of the selected job, from its progress metrics. */
function addMetricPoint(p) {
  const m = p && p.metrics;
  if (!m || !(m.rel_mse > 0)) return;
  const t = elapsedOf(p) ?? 0;
  const pts = state.metricPoints;
  if (!pts.length || t > pts[pts.length - 1][0]) pts.push([t, m.rel_mse]);
  else pts[pts.length - 1] = [t, m.rel_mse];
  renderMetricsChart(m);
}

function renderMetricsChart(m) {
  const pts = state.metricPoints;
  $('metrics-panel').hidden = !pts.length;
  if (!pts.length) return;
  const W = 240, H = 120, L = 34, B = 16;
  const tMax = Math.max(...pts.map((q) => q[0]), 1e-3);
  const ys = pts.map((q) => Math.log10(q[1]));
  let lo = Math.floor(Math.min(...ys)), hi = Math.ceil(Math.max(...ys));
  if (hi === lo) hi = lo + 1;
  const x = (t) => L + (t / tMax) * (W - L - 4);
  const y = (v) => 4 + (1 - (Math.log10(v) - lo) / (hi - lo)) * (H - B - 4);
  const svg = $('metrics-chart');
  const parts = [];
  for (let e = lo; e <= hi; e++) {
    const yy = y(10 ** e);
    parts.push(`<line x1="${L}" x2="${W - 4}" y1="${yy}" y2="${yy}" class="grid"/>`,
      `<text x="${L - 3}" y="${yy + 3}" text-anchor="end">1e${e}</text>`);
  }
  parts.push(`<text x="${W - 4}" y="${H - 3}" text-anchor="end">${fmtDuration(tMax)}</text>`,
    `<text x="${L}" y="${H - 3}">0 s · relMSE</text>`,
    `<polyline class="line" points="${pts.map((q) => `${x(q[0]).toFixed(1)},${y(q[1]).toFixed(1)}`).join(' ')}"/>`);
  svg.innerHTML = parts.join('');
  if (m) {
    $('metrics-text').textContent = `relMSE ${fmtNum(m.rel_mse)} · FLIP ${fmtNum(m.flip)} · SSIM ${m.ssim == null ? '—' : fmtNum(m.ssim)} · PSNR ${m.psnr_db == null ? '—' : fmtNum(m.psnr_db)} dB`;
  }
}

/** Updates one row in place (progress events of the selected job). */
function renderJobRow(id) {
  const li = $('job-list').querySelector(`li[data-id="${CSS.escape(id)}"]`);
  const job = state.jobs.get(id);
  if (li && job) updateJobRow(li, job);
}

function buildJobRow(id) {
  const li = el('li', { class: 'job', 'data-id': id });
  const open = el('button', { class: 'job-open', type: 'button', onclick: () => selectJob(id) },
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
  const setA = el('button', { class: 'job-set-a secondary small', type: 'button', text: 'A', onclick: () => setAb('a', id) });
  const setB = el('button', { class: 'job-set-b secondary small', type: 'button', text: 'B', onclick: () => setAb('b', id) });
  li.append(
    el('div', { class: 'job-top' }, open, badge),
    el('div', { class: 'job-mid' }, progress, budget),
    el('div', { class: 'job-actions' },
      el('label', { class: 'job-prio-label', for: prioId, text: 'Priority' }), prio,
      pause, cancel,
      el('span', { class: 'job-ab', role: 'group', 'aria-label': 'Compare' }, setA, setB)),
    el('p', { class: 'job-error error', hidden: '' }),
  );
  return li;
}

function updateJobRow(li, job) {
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
  q('.job-set-a').setAttribute('aria-label', `Compare ${name} as A`);
  q('.job-set-b').setAttribute('aria-label', `Compare ${name} as B`);
  q('.job-set-a').setAttribute('aria-pressed', String(state.ab.a === id));
  q('.job-set-b').setAttribute('aria-pressed', String(state.ab.b === id));

  const err = q('.job-error');
  const message = job.error && (job.error.message || job.error);
  err.hidden = !(st === 'failed' && message);
  err.textContent = st === 'failed' && message ? String(message) : '';
}

async function jobAction(id, fn) {
  const li = $('job-list').querySelector(`li[data-id="${CSS.escape(id)}"]`);
  const errP = li && li.querySelector('.job-error');
  try {
    const job = await fn();
    if (job && job.id != null) upsertJob(job);
    if (errP) errP.hidden = true;
    renderJobs();
    if (state.selected === id && job && job.id != null) renderViewHeader(job);
  } catch (err) {
    if (errP) {
      errP.textContent = err.describe ? err.describe() : String(err);
      errP.hidden = false;
    }
  }
  refreshJobs();
}

function pauseResume(id) {
  const job = state.jobs.get(id);
  const verb = job && job.state === 'paused' ? 'resume' : 'pause';
  return jobAction(id, () => api(`${jobLinks(job).self}/${verb}`, { method: 'POST' }));
}

function cancelJob(id) {
  const job = state.jobs.get(id);
  return jobAction(id, () => api(jobLinks(job).self, { method: 'DELETE' }));
}

function setPriority(id, input) {
  const job = state.jobs.get(id);
  const p = Number(input.value);
  if (!Number.isInteger(p) || p < 1) {
    input.value = job.priority ?? '';
    return;
  }
  return jobAction(id, () => api(jobLinks(job).self, { method: 'PATCH', json: { priority: p } }));
}

// ---------------------------------------------------------------------------------------------
// Viewer: the selected job, live over SSE
// ---------------------------------------------------------------------------------------------

const viewSlot = new ImageSlot(
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

function toneParams() {
  return { exposure: state.tone.exposure, tonemap: state.tone.tonemap };
}

/** PNG URL of a job (or of a snapshot URL) with the current exposure and tonemap. Requests
 *  are made with cache: 'no-store', so the same URL fetches the newest snapshot each time. */
function pngUrl(job, snapshotUrl) {
  return withQuery(snapshotUrl || jobLinks(job).png, toneParams());
}

function selectJob(id, { force = false } = {}) {
  if (state.selected === id && !force) {
    $('viewer').focus({ preventScroll: true });
    return;
  }
  if (state.stream) state.stream.close();
  state.stream = null;
  state.selected = id;
  state.live = null;
  state.snapshotUrl = null;
  state.metricPoints = [];
  renderMetricsChart();
  viewSlot.reset();
  $('view-image').hidden = true;
  $('stage-placeholder').hidden = false;
  $('stage-placeholder').textContent = 'Loading…';
  $('view-message').textContent = '';
  history.replaceState(null, '', `#job=${encodeURIComponent(id)}`);
  showTab('single');
  renderJobs();

  const known = state.jobs.get(id);
  if (known) renderViewHeader(known);
  api(`/api/jobs/${encodeURIComponent(id)}`)
    .then((job) => {
      if (state.selected !== id) return;
      upsertJob(job);
      renderViewHeader(job);
      renderStats(job, jobNumbers(job));
      addMetricPoint(jobProgress(job));
      if (jobSpp(job) > 0 || job.state === 'done') viewSlot.load(pngUrl(job), { spp: jobSpp(job), job: id });
      else $('stage-placeholder').textContent = job.state === 'queued' ? 'Queued: waiting for the GPU…' : 'Waiting for the first snapshot…';
      if (!TERMINAL.has(job.state)) openStream(job);
    })
    .catch((err) => {
      if (state.selected !== id) return;
      $('stage-placeholder').textContent = `Cannot load job ${id}: ${err.describe ? err.describe() : err.message}`;
    });
}

function openStream(job) {
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
      addMetricPoint(d);
      renderJobRow(id);
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
  });
  stream.finishSoon = finishSoon;
  state.stream = stream;
}

function closeStream(id) {
  if (state.selected === id && state.stream) {
    state.stream.close();
    state.stream = null;
  }
  refreshJobs();
}

/** Keeps the viewer consistent with the polled list (e.g. a state change while reconnecting). */
function syncSelectedFromList() {
  const id = state.selected;
  const job = id && state.jobs.get(id);
  if (!job) return;
  renderViewHeader(job);
  if (!state.live) renderStats(job, jobNumbers(job));
  if (!state.stream && !TERMINAL.has(job.state)) openStream(job);
  else if (state.stream && job.state === 'done') state.stream.finishSoon();
  else if (state.stream && TERMINAL.has(job.state)) closeStream(id);
}

function renderViewHeader(job) {
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

function renderStats(job, p) {
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
}

function fitViewImage() {
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

function updateDownloads() {
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
async function download(ev) {
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

function renderTone() {
  const e = state.tone.exposure;
  $('exposure').value = String(e);
  $('exposure-value').textContent = `${e >= 0 ? '+' : '−'}${Math.abs(e).toFixed(1)} EV`;
  $('tonemap').value = state.tone.tonemap;
}

const applyTone = debounce(() => {
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
  refreshAbImages(true);
}, 150);

function initTone() {
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

// ---------------------------------------------------------------------------------------------
// Tabs
// ---------------------------------------------------------------------------------------------

function showTab(which) {
  const single = which === 'single';
  $('tab-single').setAttribute('aria-selected', String(single));
  $('tab-ab').setAttribute('aria-selected', String(!single));
  $('tab-single').tabIndex = single ? 0 : -1;
  $('tab-ab').tabIndex = single ? -1 : 0;
  $('pane-single').hidden = !single;
  $('pane-ab').hidden = single;
  if (single) fitViewImage();
  else {
    autoPickAb();
    refreshAbImages(true);
  }
}

function initTabs() {
  const tabs = [$('tab-single'), $('tab-ab')];
  tabs.forEach((t, i) => {
    t.addEventListener('click', () => showTab(i === 0 ? 'single' : 'ab'));
    t.addEventListener('keydown', (e) => {
      if (e.key !== 'ArrowLeft' && e.key !== 'ArrowRight') return;
      const next = tabs[(i + 1) % 2];
      showTab(next === tabs[0] ? 'single' : 'ab');
      next.focus();
      e.preventDefault();
    });
  });
}

// ---------------------------------------------------------------------------------------------
// A/B comparison: two stacked images, B clipped to the right of a draggable divider
// ---------------------------------------------------------------------------------------------

const abSlots = {
  a: new ImageSlot($('ab-img-a'), () => layoutAb(), (err) => abError('A', err)),
  b: new ImageSlot($('ab-img-b'), () => layoutAb(), (err) => abError('B', err)),
};
const abShown = { a: null, b: null }; // "id@spp@tone" of what each side shows

function abError(side, err) {
  $('ab-placeholder').hidden = false;
  $('ab-placeholder').textContent = `${side}: ${err.status === 404 ? 'no image yet' : err.describe ? err.describe() : err.message}`;
}

function comparable(job) {
  return job && (job.state === 'done' || jobSpp(job) > 0);
}

function renderAbOptions() {
  for (const side of ['a', 'b']) {
    const sel = $(`ab-${side}`);
    const want = state.ab[side];
    const opts = [el('option', { value: '', text: '— pick a job —' })];
    for (const id of state.order) {
      const job = state.jobs.get(id);
      if (!comparable(job) && id !== want) continue;
      opts.push(el('option', { value: id, text: `${jobName(job)} (#${id}, ${jobIntegrator(job)}, ${jobSpp(job)} spp)` }));
    }
    // Only rebuild when the option list changed (keeps an open select usable).
    const sig = opts.map((o) => `${o.value}:${o.textContent}`).join('|');
    if (sel.dataset.sig !== sig) {
      sel.replaceChildren(...opts);
      sel.dataset.sig = sig;
    }
    sel.value = want;
  }
}

function autoPickAb() {
  if (state.ab.a && state.ab.b) return;
  const candidates = state.order.filter((id) => comparable(state.jobs.get(id)));
  if (!state.ab.a) state.ab.a = candidates.find((id) => id !== state.ab.b) || '';
  if (!state.ab.b) state.ab.b = candidates.find((id) => id !== state.ab.a) || '';
  renderAbOptions();
  renderJobs();
}

function setAb(side, id) {
  state.ab[side] = id;
  renderAbOptions();
  renderJobs();
  showTab('ab');
}

/** Loads A and B when the job, its spp or the tone settings changed (force: reload anyway). */
function refreshAbImages(force = false) {
  if ($('pane-ab').hidden) return;
  const t = `${state.tone.exposure}/${state.tone.tonemap}`;
  let any = false;
  for (const side of ['a', 'b']) {
    const id = state.ab[side];
    const job = id && state.jobs.get(id);
    const img = $(`ab-img-${side}`);
    if (!job) {
      abSlots[side].reset();
      abShown[side] = null;
      img.hidden = true;
      continue;
    }
    any = true;
    img.hidden = false;
    const key = `${id}@${jobSpp(job)}@${job.state}@${t}`;
    if (!force && abShown[side] === key) continue;
    if (abShown[side] && abShown[side].split('@')[0] !== id) abSlots[side].reset();
    abShown[side] = key;
    abSlots[side].load(pngUrl(job), { job: id, spp: jobSpp(job) });
    $(`ab-label-${side}`).textContent = `${side.toUpperCase()}: ${jobName(job)} · ${jobIntegrator(job)} · ${jobSpp(job)} spp`;
  }
  $('ab-placeholder').hidden = any;
  $('ab-placeholder').textContent = 'Pick two jobs to compare.';
  $('ab-frame').hidden = !any;
  setAbPos(state.ab.pos);
}

function layoutAb() {
  const a = $('ab-img-a');
  const b = $('ab-img-b');
  const ref = a.naturalWidth ? a : b;
  if (!ref.naturalWidth) return;
  const stage = $('ab-stage');
  const box = fitBox(ref.naturalWidth, ref.naturalHeight, stage.clientWidth - 2, availHeight());
  const frame = $('ab-frame');
  frame.style.width = `${box.w}px`;
  frame.style.height = `${box.h}px`;
  frame.classList.toggle('pixelated', box.pixelated);
  $('ab-placeholder').hidden = true;
}

function setAbPos(pos) {
  const p = Math.max(0, Math.min(100, Math.round(pos * 10) / 10));
  state.ab.pos = p;
  $('ab-img-b').style.clipPath = `inset(0 0 0 ${p}%)`;
  const d = $('ab-divider');
  d.style.left = `${p}%`;
  d.setAttribute('aria-valuenow', String(p));
  d.setAttribute('aria-valuetext', `${Math.round(p)}% A, ${Math.round(100 - p)}% B`);
}

function initAb() {
  for (const side of ['a', 'b']) {
    $(`ab-${side}`).addEventListener('change', (e) => {
      state.ab[side] = e.target.value;
      renderJobs();
      refreshAbImages();
    });
  }
  $('ab-swap').addEventListener('click', () => {
    [state.ab.a, state.ab.b] = [state.ab.b, state.ab.a];
    renderAbOptions();
    renderJobs();
    refreshAbImages(true);
  });

  const frame = $('ab-frame');
  const divider = $('ab-divider');
  const posFromEvent = (e) => {
    const r = frame.getBoundingClientRect();
    return ((e.clientX - r.left) / r.width) * 100;
  };
  frame.addEventListener('pointerdown', (e) => {
    if (e.button !== 0) return;
    frame.setPointerCapture(e.pointerId);
    frame.classList.add('dragging');
    setAbPos(posFromEvent(e));
    divider.focus({ preventScroll: true });
    e.preventDefault();
  });
  frame.addEventListener('pointermove', (e) => {
    if (frame.hasPointerCapture(e.pointerId)) setAbPos(posFromEvent(e));
  });
  const stop = (e) => {
    if (frame.hasPointerCapture(e.pointerId)) frame.releasePointerCapture(e.pointerId);
    frame.classList.remove('dragging');
  };
  frame.addEventListener('pointerup', stop);
  frame.addEventListener('pointercancel', stop);

  divider.addEventListener('keydown', (e) => {
    const step = e.shiftKey ? 10 : 1;
    const moves = {
      ArrowLeft: -step, ArrowDown: -step, ArrowRight: step, ArrowUp: step, PageDown: -10, PageUp: 10,
    };
    if (e.key in moves) setAbPos(state.ab.pos + moves[e.key]);
    else if (e.key === 'Home') setAbPos(0);
    else if (e.key === 'End') setAbPos(100);
    else return;
    e.preventDefault();
  });
  setAbPos(50);
}

// ---------------------------------------------------------------------------------------------
// Start
// ---------------------------------------------------------------------------------------------

function init() {
  initToken();
  initForm();
  initTone();
  initTabs();
  initAb();
  $('state-filter').addEventListener('change', refreshJobs);
  for (const a of [$('download-png'), $('download-exr')]) a.addEventListener('click', download);
  const onResize = debounce(() => {
    fitViewImage();
    layoutAb();
  }, 100);
  window.addEventListener('resize', onResize);
  document.addEventListener('visibilitychange', () => {
    if (!document.hidden) refreshJobs();
  });

  checkHealth();
  loadScenes();
  refreshJobs();
  const m = /^#job=(.+)$/.exec(location.hash);
  if (m) selectJob(decodeURIComponent(m[1]));
  document.body.dataset.ready = 'true';
}

init();
