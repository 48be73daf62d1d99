// candela web viewer, entry module: the token box and start-up. The client talks to the render
// server's JSON API, streams job events over SSE, shows the refining image with exposure and
// tonemap and a live error chart against a reference, manages the job queue and compares two
// jobs' images. Plain modern JavaScript modules, no dependencies, no build step:
//   util.js (helpers) · api.js (API, SSE, server status) · state.js (state, job fields) ·
//   images.js (image loading) · form.js (new render) · jobs.js (job list) ·
//   viewer.js (selected job, tone) · chart.js (error chart) · ab.js (tabs, A/B compare) ·
//   farm.js (the workers table)

import { $, STORE, debounce } from './util.js';
import { checkHealth, getToken } from './api.js';
import { state } from './state.js';
import { initForm, loadIntegrators, loadScenes } from './form.js';
import { refreshJobs } from './jobs.js';
import { download, fitViewImage, initTone, initViewer, selectJob } from './viewer.js';
import { initAb, initTabs, layoutAb } from './ab.js';
import { initFarm } from './farm.js';

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
  loadIntegrators();
  refreshJobs();
  if (state.selected) selectJob(state.selected, { force: true });
}

// ---------------------------------------------------------------------------------------------
// Start
// ---------------------------------------------------------------------------------------------

function init() {
  initToken();
  initForm();
  initTone();
  initViewer();
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
  setInterval(checkHealth, 15000); // free space and held jobs (the storage banner)
  loadScenes();
  loadIntegrators();
  refreshJobs();
  initFarm();
  const m = /^#job=(.+)$/.exec(location.hash);
  if (m) selectJob(decodeURIComponent(m[1]));
  document.body.dataset.ready = 'true';
}

init();
