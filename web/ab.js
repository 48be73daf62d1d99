// candela web viewer: the Image / A-B tabs and the A/B comparison (two stacked images, B clipped
// to the right of a divider moved by mouse, touch or keyboard).

import { $, el } from './util.js';
import { on, state, jobIntegrator, jobName, jobSpp } from './state.js';
import { ImageSlot, availHeight, fitBox } from './images.js';
import { renderJobs } from './jobs.js';
import { fitViewImage, pngUrl } from './viewer.js';

// ---------------------------------------------------------------------------------------------
// Tabs
// ---------------------------------------------------------------------------------------------

export function showTab(which) {
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

export function initTabs() {
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

export const abSlots = {
  a: new ImageSlot($('ab-img-a'), () => layoutAb(), (err) => abError('A', err)),
  b: new ImageSlot($('ab-img-b'), () => layoutAb(), (err) => abError('B', err)),
};
export const abShown = { a: null, b: null }; // "id@spp@tone" of what each side shows

export function abError(side, err) {
  $('ab-placeholder').hidden = false;
  $('ab-placeholder').textContent = `${side}: ${err.status === 404 ? 'no image yet' : err.describe ? err.describe() : err.message}`;
}

export function comparable(job) {
  return job && (job.state === 'done' || jobSpp(job) > 0);
}

export function renderAbOptions() {
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

export function autoPickAb() {
  if (state.ab.a && state.ab.b) return;
  const candidates = state.order.filter((id) => comparable(state.jobs.get(id)));
  if (!state.ab.a) state.ab.a = candidates.find((id) => id !== state.ab.b) || '';
  if (!state.ab.b) state.ab.b = candidates.find((id) => id !== state.ab.a) || '';
  renderAbOptions();
  renderJobs();
}

export function setAb(side, id) {
  state.ab[side] = id;
  renderAbOptions();
  renderJobs();
  showTab('ab');
}

/** Loads A and B when the job, its spp or the tone settings changed (force: reload anyway). */
export function refreshAbImages(force = false) {
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

export function layoutAb() {
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

export function setAbPos(pos) {
  const p = Math.max(0, Math.min(100, Math.round(pos * 10) / 10));
  state.ab.pos = p;
  $('ab-img-b').style.clipPath = `inset(0 0 0 ${p}%)`;
  const d = $('ab-divider');
  d.style.left = `${p}%`;
  d.setAttribute('aria-valuenow', String(p));
  d.setAttribute('aria-valuetext', `${Math.round(p)}% A, ${Math.round(100 - p)}% B`);
}

export function initAb() {
  on('jobs-rendered', renderAbOptions);
  on('jobs-refreshed', () => refreshAbImages());
  on('set-ab', setAb);
  on('job-selected', () => showTab('single'));
  on('tone-changed', () => refreshAbImages(true));
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
