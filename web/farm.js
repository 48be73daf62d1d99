// candela web viewer: the farm table — every worker the server's store knows of
// (GET /api/workers: each worker's last heartbeat report), with its state, GPU, the jobs it
// renders (and which shard of a split job), its samples per second, its process's resident
// memory and its kernel variants (cached / seen since it started). Hidden while no worker
// has reported (a server that renders alone shows itself once it has).

import { $, el, fmtBytes, fmtSi } from './util.js';
import { api } from './api.js';

/** One job a worker holds: "#12" or "#12 shard 3", with its spp. */
function jobText(j) {
  const shard = j.shard === null || j.shard === undefined ? '' : ` shard ${j.shard}`;
  return `#${j.job}${shard} (${j.spp}/${j.target_spp ?? '?'} spp)`;
}

/** "12 / 40": the kernel variants a worker caches and has seen, or — when unknown. */
function kernelsText(w) {
  if (w.pipelines_cached == null || w.kernel_variants_seen == null) return '—';
  return `${w.pipelines_cached} / ${w.kernel_variants_seen}`;
}

export async function refreshFarm() {
  let workers;
  try {
    workers = (await api('/api/workers')).workers || [];
  } catch {
    return; // the status line reports an unreachable server
  }
  $('farm').hidden = workers.length === 0;
  const rows = workers.map((w) =>
    el(
      'tr',
      { class: `worker-${w.state}` },
      el('td', { text: w.name }),
      el('td', { text: w.state }),
      el('td', { text: w.device || '—' }),
      el('td', { text: (w.jobs || []).map(jobText).join(', ') || 'idle' }),
      el('td', { text: w.state === 'running' ? fmtSi(w.samples_per_s || 0) : '—' }),
      el('td', { text: fmtBytes(w.rss_bytes) }),
      el('td', { text: kernelsText(w) }),
    ),
  );
  $('farm-rows').replaceChildren(...rows);
}

/** Starts the table's polling. */
export function initFarm() {
  refreshFarm();
  setInterval(() => {
    if (!document.hidden) refreshFarm();
  }, 5000);
}
