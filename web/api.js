// candela web viewer: the JSON API (/api/...) with the bearer token, server-sent events read
// over fetch (so the token can be sent), and the server status line / 401 handling.

import { $, STORE, sleep } from './util.js';
import { state } from './state.js';

// ---------------------------------------------------------------------------------------------
// API access (bearer token from local storage; errors are {"error": {code, message, path?}})
// ---------------------------------------------------------------------------------------------

export class ApiError extends Error {
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

export function getToken() {
  try {
    return localStorage.getItem(STORE.token) || '';
  } catch {
    return '';
  }
}

export function authHeaders() {
  const t = getToken();
  return t ? { Authorization: `Bearer ${t}` } : {};
}

export async function toApiError(res) {
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
export async function api(path, { method = 'GET', json, body, signal } = {}) {
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
export function withQuery(url, params) {
  const u = new URL(url, location.href);
  for (const [k, v] of Object.entries(params)) {
    if (v == null || v === '') u.searchParams.delete(k);
    else u.searchParams.set(k, String(v));
  }
  return u.origin === location.origin ? u.pathname + u.search : u.href;
}


// ---------------------------------------------------------------------------------------------
// Server-sent events over fetch: same wire format as EventSource, but it can send the
// Authorization header, reconnects with Last-Event-ID, and has no clash with a custom "error"
// event type.
// ---------------------------------------------------------------------------------------------

export class EventStream {
  /** handlers: {event name: fn(data, id)}; onStatus(text) for connection state; lastId: start
   *  after this event id (Last-Event-ID). */
  constructor(url, handlers, onStatus = () => {}, { lastId = null } = {}) {
    this.url = url;
    this.handlers = handlers;
    this.onStatus = onStatus;
    this.lastId = lastId; // '0': replay every stored event, not just the latest progress
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

export function noteUnauthorized() {
  if (state.unauthorized) return;
  state.unauthorized = true;
  setServerStatus(getToken() ? 'The access token was refused.' : 'This server needs an access token.', 'bad');
  $('token-box').open = true;
}

export function setServerStatus(text, kind = '') {
  const s = $('server-status');
  s.textContent = text;
  s.dataset.kind = kind;
}

// The banner shown while the data directory is short of space (new jobs get 507) or jobs are
// held paused after a write failed for lack of space.
function renderStorage(s) {
  const b = $('storage-banner');
  if (!b) return;
  const gb = (n) => `${(n / 1e9).toFixed(2)} GB`;
  const bits = [];
  if (s && s.low) {
    bits.push(`Disk space low: ${gb(s.free_bytes)} free in ${s.data_dir}, below the server's minimum of ${gb(s.min_free_bytes)}; new jobs are refused until space is freed (delete finished jobs).`);
  }
  if (s && s.held_jobs > 0) {
    bits.push(`${s.held_jobs} job(s) paused because the disk is full; they resume when space returns.`);
  }
  b.textContent = bits.join(' ');
  b.hidden = bits.length === 0;
}

export async function checkHealth() {
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
    renderStorage(h && h.storage);
    setServerStatus(bits.filter(Boolean).join(' · '), h && h.status && h.status !== 'ok' ? 'warn' : 'ok');
  } catch (err) {
    if (err.status === 401) return; // noteUnauthorized said it
    if (err.status === 404) setServerStatus('Connected', 'ok');
    else setServerStatus(`Server: ${err.describe()}`, 'bad');
  }
}
