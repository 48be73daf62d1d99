// candela web viewer: small DOM and formatting helpers shared by every module.

// ---------------------------------------------------------------------------------------------
// Small helpers
// ---------------------------------------------------------------------------------------------

export const $ = (id) => document.getElementById(id);
export const TERMINAL = new Set(['done', 'failed', 'canceled']);
export const STORE = {
  token: 'candela.token',
  tone: 'candela.tone',
};

export const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

export function debounce(fn, ms) {
  let t = 0;
  return (...args) => {
    clearTimeout(t);
    t = setTimeout(() => fn(...args), ms);
  };
}

export function el(tag, attrs = {}, ...children) {
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

export function fmtDuration(s) {
  if (s == null || !Number.isFinite(s) || s < 0) return '—';
  if (s < 59.5) return `${s.toFixed(s < 9.95 ? 1 : 0)} s`;
  const total = Math.round(s);
  const m = Math.floor(total / 60);
  if (m < 60) return `${m} min ${String(total - m * 60).padStart(2, '0')} s`;
  const h = Math.floor(m / 60);
  return `${h} h ${String(m - h * 60).padStart(2, '0')} min`;
}

export function fmtSi(x) {
  if (x == null || !Number.isFinite(x)) return '—';
  const units = [[1e12, 'T'], [1e9, 'G'], [1e6, 'M'], [1e3, 'k']];
  for (const [f, u] of units) if (Math.abs(x) >= f) return `${(x / f).toPrecision(3)} ${u}`;
  return x.toPrecision(3);
}

/** Bytes as "612 MiB" / "1.25 GiB" (binary units), or — when unknown. */
export function fmtBytes(b) {
  if (b == null || !Number.isFinite(b) || b < 0) return '—';
  const units = [[2 ** 30, 'GiB'], [2 ** 20, 'MiB'], [2 ** 10, 'KiB']];
  for (const [f, u] of units) if (b >= f) return `${fmtNum(b / f)} ${u}`;
  return `${b} B`;
}

export function fmtNum(x, digits = 3) {
  if (x == null || !Number.isFinite(x)) return '—';
  return x >= 100 ? x.toFixed(0) : x.toPrecision(digits);
}
