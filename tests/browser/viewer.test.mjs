// Browser test of the candela web viewer in headless Chromium (the system /usr/bin/chromium,
// driven by playwright-core; no browser is ever downloaded). It starts nothing itself:
//
//   node tests/browser/viewer.test.mjs SERVER_URL OUT_DIR [--token T]
//
// It opens the viewer, submits the Cornell box at 32×32, checks the image refines live (at least
// two snapshots with increasing spp) and the job reaches "done" in the list, exercises exposure
// and tonemap, the EXR download, the A/B view with two jobs, pause/resume/priority/cancel/delete, the
// other scene sources (pasted JSON, a scene file with assets, a .tar folder) and the error display,
// then a job with job A as its reference: its live error chart (relMSE, log scale) beside the image
// at 1360 px and below it at 640 px, its last value against the job's progress events. It saves
// screenshots into OUT_DIR (viewer.png is the main one). Exits 0 on
// success, 1 with a "FAIL: <step>: <why>" line (and OUT_DIR/failure.png) otherwise.

import { mkdtempSync, mkdirSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

// ---- arguments -------------------------------------------------------------------------------

const args = process.argv.slice(2);
const flag = (name) => {
  const i = args.indexOf(name);
  if (i < 0) return undefined;
  const v = args[i + 1];
  args.splice(i, 2);
  return v;
};
const token = flag('--token') ?? process.env.CANDELA_TOKEN ?? '';
if (args.length !== 2) {
  console.error('usage: node viewer.test.mjs SERVER_URL OUT_DIR [--token T]');
  process.exit(2);
}
const base = new URL(args[0]);
const outDir = resolve(args[1]);
mkdirSync(outDir, { recursive: true });

const CHROMIUM = process.env.CHROMIUM || '/usr/bin/chromium';
const SIZE = 32; // image size: tiny, so it renders quickly on lavapipe
const RENDER_TIMEOUT = Number(process.env.CANDELA_BROWSER_RENDER_TIMEOUT_MS || 180_000);

// ---- tiny test harness -----------------------------------------------------------------------

let page;
let context;
let userDataDir;
const pageErrors = [];
const consoleErrors = [];
const foreignRequests = [];
const screenshots = [];

class Failure extends Error {}
function check(cond, message) {
  if (!cond) throw new Failure(message);
}

async function step(name, fn) {
  const t0 = Date.now();
  try {
    await fn();
    console.log(`ok   ${name} (${((Date.now() - t0) / 1000).toFixed(1)} s)`);
  } catch (err) {
    console.error(`FAIL: ${name}: ${err instanceof Failure ? err.message : err.stack || err}`);
    await finish(1);
  }
}

async function shot(file, locator) {
  const path = join(outDir, file);
  if (locator) await locator.screenshot({ path });
  else await page.screenshot({ path, fullPage: true });
  screenshots.push(path);
  console.log(`     screenshot ${path}`);
}

async function finish(code) {
  if (code !== 0 && page) {
    try {
      await shot('failure.png');
      writeFileSync(join(outDir, 'failure.html'), await page.content());
    } catch {
      /* the page may be gone */
    }
  }
  if (pageErrors.length) console.error(`page errors:\n  ${pageErrors.join('\n  ')}`);
  if (consoleErrors.length) console.error(`console errors (informational):\n  ${consoleErrors.join('\n  ')}`);
  try {
    if (context) await context.close();
  } catch {
    /* already closed */
  }
  if (userDataDir) rmSync(userDataDir, { recursive: true, force: true });
  console.log(code === 0 ? `PASS (${screenshots.length} screenshots in ${outDir})` : 'browser test failed');
  process.exit(code);
}

const hardTimeout = setTimeout(() => {
  console.error('FAIL: the browser test ran over 10 minutes');
  finish(1);
}, 600_000);
hardTimeout.unref();

// ---- page helpers ----------------------------------------------------------------------------

const jobRow = (id) => page.locator(`#job-list li[data-id="${id}"]`);
const rowState = (id) => jobRow(id).getAttribute('data-state');

/** Waits until the job's row shows `state`; on timeout says which state it was stuck in. */
async function waitRowState(id, states, timeout = RENDER_TIMEOUT) {
  const want = Array.isArray(states) ? states : [states];
  try {
    await page.waitForFunction(
      ([jid, ws]) => ws.includes(document.querySelector(`#job-list li[data-id="${jid}"]`)?.dataset.state),
      [id, want],
      { timeout, polling: 200 },
    );
  } catch {
    const now = await rowState(id).catch(() => 'missing');
    const err = await jobRow(id).locator('.job-error').textContent().catch(() => '');
    throw new Failure(`job ${id} did not reach ${want.join('/')} within ${timeout / 1000} s (it is ${now})${err ? `: ${err}` : ''}`);
  }
}

/** Fills the form for a built-in scene and submits it; returns the new job's id. */
async function submitExample(settings) {
  await page.getByLabel('Example', { exact: true }).check();
  await page.getByLabel('Example scene').selectOption('cornell');
  return submitForm(settings);
}

/** Fills the job settings (the scene source is already chosen), submits from the keyboard and
 *  returns the new job's id. */
async function submitForm({ name, integrator, spp, timeS, seed = 1, priority = 10, size = SIZE }) {
  await page.getByLabel('Name').fill(name);
  await page.getByLabel('Integrator', { exact: true }).selectOption(integrator);
  if (timeS != null) {
    await page.getByLabel('Time (s)').check();
    await page.getByLabel('Budget value').fill(String(timeS));
  } else {
    await page.getByLabel('Samples per pixel', { exact: true }).check();
    await page.getByLabel('Budget value').fill(String(spp));
  }
  await page.getByLabel('Seed').fill(String(seed));
  await page.getByLabel('Priority', { exact: true }).fill(String(priority));
  await page.getByLabel('Width').fill(String(size));
  await page.getByLabel('Height').fill(String(size));
  const before = await page.evaluate(() => location.hash);
  // Submit from the keyboard (Enter in a field submits the form).
  await page.getByLabel('Height').press('Enter');
  await page.waitForFunction((h) => location.hash.startsWith('#job=') && location.hash !== h, before, { timeout: 15_000 })
    .catch(async () => {
      const err = await page.locator('#submit-error').textContent();
      throw new Failure(`submitting "${name}" did not create a job: ${err || 'no error shown'}`);
    });
  const id = await page.evaluate(() => decodeURIComponent(location.hash.slice(5)));
  await jobRow(id).waitFor({ timeout: 10_000 });
  return id;
}

/** A POSIX ustar archive of `files` ([{name, data}]), enough for a scene folder upload. */
function tar(files) {
  const blocks = [];
  const octal = (n, width) => `${n.toString(8).padStart(width - 1, '0')}\0`;
  for (const f of files) {
    const h = Buffer.alloc(512);
    h.write(f.name, 0, 100);
    h.write(octal(0o644, 8), 100);
    h.write(octal(0, 8), 108);
    h.write(octal(0, 8), 116);
    h.write(octal(f.data.length, 12), 124);
    h.write(octal(Math.floor(Date.now() / 1000), 12), 136);
    h.write('        ', 148); // checksum field counts as spaces
    h.write('0', 156);
    h.write('ustar\0', 257);
    h.write('00', 263);
    let sum = 0;
    for (const b of h) sum += b;
    h.write(`${sum.toString(8).padStart(6, '0')}\0 `, 148);
    blocks.push(h, f.data, Buffer.alloc((512 - (f.data.length % 512)) % 512));
  }
  blocks.push(Buffer.alloc(1024));
  return Buffer.concat(blocks);
}

/** Mean of R+G+B (0..765) over an <img> currently shown, read back through a canvas. */
function meanBrightness(selector) {
  return page.evaluate((sel) => {
    const img = document.querySelector(sel);
    if (!img || !img.naturalWidth) return null;
    const c = document.createElement('canvas');
    c.width = img.naturalWidth;
    c.height = img.naturalHeight;
    const g = c.getContext('2d');
    g.drawImage(img, 0, 0);
    const d = g.getImageData(0, 0, c.width, c.height).data;
    let sum = 0;
    for (let i = 0; i < d.length; i += 4) sum += d[i] + d[i + 1] + d[i + 2];
    return sum / (d.length / 4);
  }, selector);
}

/** Waits until the viewer image was loaded from a URL matching `re`. */
async function waitImageUrl(selector, re, what) {
  try {
    await page.waitForFunction(
      ([sel, src]) => {
        const img = document.querySelector(sel);
        return img && img.naturalWidth > 0 && new RegExp(src).test(img.dataset.url || '');
      },
      [selector, re.source],
      { timeout: 20_000, polling: 100 },
    );
  } catch {
    const url = await page.locator(selector).getAttribute('data-url');
    throw new Failure(`${what}: ${selector} was not reloaded with ${re} (last image URL: ${url})`);
  }
}

// ---- the test --------------------------------------------------------------------------------

await step('launch Chromium', async () => {
  userDataDir = mkdtempSync(join(tmpdir(), 'candela-chromium-'));
  context = await chromium.launchPersistentContext(userDataDir, {
    executablePath: CHROMIUM,
    headless: true,
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync',
      // Containers often have a tiny /dev/shm; Chromium then crashes without this.
      '--disable-dev-shm-usage'],
    viewport: { width: 1360, height: 900 },
    acceptDownloads: true,
  });
  page = context.pages()[0] || (await context.newPage());
  page.setDefaultTimeout(15_000);
  page.on('pageerror', (e) => pageErrors.push(String(e.stack || e)));
  page.on('console', (m) => {
    if (m.type() === 'error') consoleErrors.push(m.text());
  });
  // The viewer must not load anything from anywhere but its server (no CDN, no fonts).
  await context.route('**/*', (route) => {
    const u = new URL(route.request().url());
    if (u.protocol === 'data:' || u.protocol === 'blob:' || u.origin === base.origin) return route.continue();
    foreignRequests.push(u.href);
    return route.abort();
  });
});

await step('open the viewer', async () => {
  const res = await page.goto(base.href, { waitUntil: 'load' });
  check(res && res.ok(), `GET ${base.href} answered ${res && res.status()}`);
  await page.waitForSelector('body[data-ready="true"]');
  check((await page.title()) === 'candela', `unexpected title "${await page.title()}"`);
  if (token) {
    // Without the token the API answers 401 and the page opens the token box by itself.
    await page.waitForFunction(() => document.querySelector('#token-box').open, null, { timeout: 10_000 })
      .catch(() => { throw new Failure('the API refused the page, but the token box did not open'); });
    await page.getByLabel('Bearer token').fill(token);
    await page.getByRole('button', { name: 'Save' }).click();
    check((await page.locator('#token-state').textContent()) === '(set)', 'the token was not stored');
  }
  await page.waitForFunction(() => [...document.querySelectorAll('#scene-name option')].some((o) => o.value === 'cornell'), null, { timeout: 15_000 })
    .catch(() => { throw new Failure('the example list (GET /api/scenes) has no "cornell"'); });
  await page.waitForFunction(() => document.querySelector('#server-status').dataset.kind === 'ok', null, { timeout: 15_000 })
    .catch(async () => { throw new Failure(`server status: ${await page.locator('#server-status').textContent()}`); });
});

await step('every form control has an accessible name', async () => {
  const unnamed = await page.evaluate(() => [...document.querySelectorAll('input, select, textarea, button, [role="slider"]')]
    .filter((e) => !(e.labels && e.labels.length) && !e.getAttribute('aria-label') && !e.getAttribute('aria-labelledby') && !e.textContent.trim())
    .map((e) => e.id || e.outerHTML.slice(0, 80)));
  check(unnamed.length === 0, `controls without a label: ${unnamed.join(', ')}`);
});

await step('bad input shows a clear error', async () => {
  await page.getByLabel('Paste JSON').check();
  await page.getByLabel('Scene JSON').fill('{"version": 1,');
  await page.getByRole('button', { name: 'Render' }).click();
  const err = page.locator('#submit-error');
  await err.waitFor({ state: 'visible' });
  check(/not valid JSON/.test(await err.textContent()), `client-side JSON error: "${await err.textContent()}"`);
  // Valid JSON, invalid scene: the server's 4xx error (with its JSON path) is shown.
  await page.getByLabel('Scene JSON').fill('{"version": 1, "film": {"width": 8, "height": 8}, "materials": {}, "objects": []}');
  await page.getByRole('button', { name: 'Render' }).click();
  await page.waitForFunction(() => /\b4\d\d\b/.test(document.querySelector('#submit-error').textContent), null, { timeout: 15_000 })
    .catch(async () => { throw new Failure(`no server error shown for an invalid scene: "${await err.textContent()}"`); });
  console.log(`     server said: ${await err.textContent()}`);
});

let jobA;
await step('submit the Cornell box (nee, 32×32) and watch it refine', async () => {
  // Record every image the viewer shows: (job, spp) per update of <img src>.
  await page.evaluate(() => {
    window.__updates = [];
    const img = document.querySelector('#view-image');
    new MutationObserver(() => {
      if (img.getAttribute('src')) window.__updates.push({ job: img.dataset.job, spp: Number(img.dataset.spp), t: performance.now() });
    }).observe(img, { attributes: true, attributeFilter: ['src'] });
  });
  jobA = await submitExample({ name: 'browser-cornell-nee', integrator: 'nee', timeS: 6 });
  console.log(`     job ${jobA}`);
  check(await jobRow(jobA).evaluate((li) => li.classList.contains('selected')), 'the new job is not selected in the list');
  await page.waitForFunction((id) => window.__updates.some((u) => u.job === id), jobA, { timeout: RENDER_TIMEOUT })
    .catch(() => { throw new Failure('no snapshot image appeared in the viewer'); });
  await shot('01-rendering.png');
  await waitRowState(jobA, 'done');
  // The final image is loaded after "done".
  await page.waitForFunction(() => document.querySelector('#view-image').dataset.final === 'true' || document.querySelector('#view-state').dataset.state === 'done', null, { timeout: 20_000 });
  await page.waitForTimeout(500);
  const updates = (await page.evaluate(() => window.__updates)).filter((u) => u.job === jobA);
  const spps = updates.map((u) => u.spp);
  console.log(`     image updates at spp ${spps.join(', ')}`);
  check(updates.length >= 2, `the image updated ${updates.length} time(s), expected at least 2`);
  check(new Set(spps).size >= 2, `the image did not refine: every update was at spp ${spps[0]}`);
  for (let i = 1; i < spps.length; i++) check(spps[i] >= spps[i - 1], `snapshot spp went backwards: ${spps.join(', ')}`);
  check(spps.every((s) => Number.isFinite(s) && s > 0), `snapshot spp not positive numbers: ${spps.join(', ')}`);
});

await step('the viewer shows the statistics and the job is done in the list', async () => {
  const text = async (id) => (await page.locator(`#${id}`).textContent()).trim();
  check(/^\d+/.test(await text('stat-spp')) && Number.parseInt(await text('stat-spp'), 10) > 0, `spp shows "${await text('stat-spp')}"`);
  check((await text('stat-elapsed')) !== '—', 'elapsed time is not shown');
  check((await text('stat-msps')) !== '—', 'Msamples/s is not shown');
  check((await text('view-state')) === 'done', `viewer state shows "${await text('view-state')}"`);
  check((await jobRow(jobA).locator('.job-state').textContent()) === 'done', 'the list badge does not say done');
  const img = page.locator('#view-image');
  const [w, h] = await img.evaluate((i) => [i.naturalWidth, i.naturalHeight]);
  check(w === SIZE && h === SIZE, `the image is ${w}×${h}, expected ${SIZE}×${SIZE}`);
  const box = await img.boundingBox();
  check(box && box.width >= 4 * SIZE, `the 32×32 image is not scaled up for viewing (${box && box.width} px wide)`);
  console.log(`     spp ${await text('stat-spp')}, elapsed ${await text('stat-elapsed')}, ${await text('stat-msps')} Msamples/s, rays/s ${await text('stat-rays')}`);
  await shot('viewer.png');
});

await step('the workers table shows the server rendering on its device', async () => {
  // The server's render loop reports with its heartbeats (GET /api/workers; farm.js polls it).
  await page.locator('#farm').waitFor({ state: 'visible', timeout: 15_000 });
  // (Until a heartbeat after the render above: the kernel variants it compiled show.)
  await page.waitForFunction(() => {
    const gpu = document.querySelector('#farm-rows tr td:nth-child(3)')?.textContent || '—';
    const kernels = document.querySelector('#farm-rows tr td:nth-child(7)')?.textContent || '';
    return gpu !== '—' && /\/ [1-9]/.test(kernels);
  }, null, { timeout: 30_000 });
  const cells = await page.locator('#farm-rows tr').first().locator('td').allTextContents();
  check(cells[1] === 'running', `the worker's state shows "${cells[1]}"`);
  check(cells[2] && cells[2] !== '—', `the worker's GPU shows "${cells[2]}"`);
  check(/^[0-9.]+ (MiB|GiB)$/.test(cells[5] || ''), `the worker's memory shows "${cells[5]}"`);
  check(/^[0-9]+ \/ [1-9][0-9]*$/.test(cells[6] || ''), `the worker's kernels (cached / seen) show "${cells[6]}"`);
  console.log(`     worker ${cells.join(' | ')}`);
});

await step('exposure and tonemap re-request the PNG', async () => {
  const sel = '#view-image';
  const b0 = await meanBrightness(sel);
  await page.getByLabel('Exposure', { exact: true }).fill('2');
  check((await page.locator('#exposure-value').textContent()).includes('+2.0'), 'the exposure readout did not follow the slider');
  await waitImageUrl(sel, /[?&]exposure=2(&|$)/, 'exposure +2');
  const b1 = await meanBrightness(sel);
  console.log(`     mean brightness: exposure 0 → ${b0.toFixed(1)}, +2 EV → ${b1.toFixed(1)}`);
  check(b1 > b0 * 1.3, `exposure +2 did not brighten the image (${b0.toFixed(1)} → ${b1.toFixed(1)})`);
  await page.getByLabel('Tonemap').selectOption('aces');
  await waitImageUrl(sel, /tonemap=aces/, 'tonemap aces');
  const b2 = await meanBrightness(sel);
  console.log(`     +2 EV with aces → ${b2.toFixed(1)}`);
  check(Math.abs(b2 - b1) > 0.5, 'switching the tonemap to aces did not change the image');
  const href = await page.locator('#download-png').getAttribute('href');
  check(/exposure=2/.test(href) && /tonemap=aces/.test(href), `the PNG download link ignores the tone settings: ${href}`);
  await shot('02-exposure-aces.png');
  // The downloads answer with real files.
  const exrHref = await page.locator('#download-exr').getAttribute('href');
  const headers = token ? { Authorization: `Bearer ${token}` } : {};
  const exr = await page.request.get(new URL(exrHref, base).href, { headers });
  const magic = (await exr.body()).subarray(0, 4);
  check(exr.ok() && magic.equals(Buffer.from([0x76, 0x2f, 0x31, 0x01])), `EXR download: HTTP ${exr.status()}, magic ${magic.toString('hex')}`);
  const png = await page.request.get(new URL(href, base).href, { headers });
  check(png.ok() && (await png.body()).subarray(1, 4).toString() === 'PNG', `PNG download: HTTP ${png.status()}`);
  // Back to neutral for the rest.
  await page.getByRole('button', { name: 'Reset exposure to 0' }).click();
  await page.getByLabel('Tonemap').selectOption('clamp');
  await waitImageUrl(sel, /exposure=0.*tonemap=clamp|tonemap=clamp.*exposure=0/, 'reset tone');
});

let jobB;
await step('a second job (pt) for the A/B view', async () => {
  jobB = await submitExample({ name: 'browser-cornell-pt', integrator: 'pt', spp: 64, seed: 2 });
  console.log(`     job ${jobB}`);
  await waitRowState(jobB, 'done');
});

await step('A/B view swipes between the two jobs', async () => {
  await jobRow(jobA).getByRole('button', { name: /as A$/ }).click();
  await jobRow(jobB).getByRole('button', { name: /as B$/ }).click();
  await page.locator('#pane-ab').waitFor({ state: 'visible' });
  check((await page.getByRole('tab', { name: 'A/B compare' }).getAttribute('aria-selected')) === 'true', 'the A/B tab is not selected');
  check((await page.getByLabel('A (left)').inputValue()) === jobA, 'A is not the first job');
  check((await page.getByLabel('B (right)').inputValue()) === jobB, 'B is not the second job');
  await page.waitForFunction(([a, b]) => {
    const ia = document.querySelector('#ab-img-a');
    const ib = document.querySelector('#ab-img-b');
    return ia.naturalWidth > 0 && ib.naturalWidth > 0 && ia.dataset.job === a && ib.dataset.job === b;
  }, [jobA, jobB], { timeout: 20_000 }).catch(() => { throw new Failure('the A/B images did not both load'); });

  const divider = page.getByRole('slider', { name: 'A/B divider position' });
  const value = async () => Number(await divider.getAttribute('aria-valuenow'));
  const clip = () => page.locator('#ab-img-b').evaluate((i) => i.style.clipPath);
  check((await value()) === 50, `the divider starts at ${await value()}, expected 50`);

  // Drag with the mouse to a quarter of the width (the frame scrolled into view first: the
  // job list's buttons may have scrolled the page past it).
  await page.locator('#ab-frame').scrollIntoViewIfNeeded();
  const frame = await page.locator('#ab-frame').boundingBox();
  check(frame && frame.width >= 4 * SIZE, 'the A/B frame is not scaled up');
  const y = frame.y + frame.height / 2;
  await page.mouse.move(frame.x + frame.width / 2, y);
  await page.mouse.down();
  await page.mouse.move(frame.x + frame.width * 0.35, y, { steps: 4 });
  await page.mouse.move(frame.x + frame.width * 0.25, y, { steps: 4 });
  await page.mouse.up();
  const dragged = await value();
  check(Math.abs(dragged - 25) <= 2, `dragging to 25% left the divider at ${dragged}`);
  check((await clip()).includes(`${dragged}%`), `B is not clipped at the divider: ${await clip()}`);

  // Keyboard: the divider is focusable and moves with the arrow keys, Home and End.
  await divider.focus();
  for (let i = 0; i < 5; i++) await page.keyboard.press('ArrowRight');
  check(Math.abs((await value()) - (dragged + 5)) < 0.01, `ArrowRight ×5 gave ${await value()}, expected ${dragged + 5}`);
  await page.keyboard.press('Shift+ArrowRight');
  check(Math.abs((await value()) - (dragged + 15)) < 0.01, `Shift+ArrowRight gave ${await value()}`);
  await page.keyboard.press('End');
  check((await value()) === 100, 'End did not move the divider to 100');
  await page.keyboard.press('Home');
  check((await value()) === 0, 'Home did not move the divider to 0');

  // Swapping A and B, then a final position for the screenshot.
  await page.getByRole('button', { name: 'Swap A and B' }).click();
  check((await page.getByLabel('A (left)').inputValue()) === jobB, 'swap did not swap');
  await page.getByRole('button', { name: 'Swap A and B' }).click();
  const frame2 = await page.locator('#ab-frame').boundingBox();
  await page.mouse.click(frame2.x + frame2.width * 0.6, frame2.y + frame2.height / 2);
  check(Math.abs((await value()) - 60) <= 2, `clicking at 60% left the divider at ${await value()}`);
  await page.waitForTimeout(300);
  await shot('03-ab.png');
  await shot('03-ab-frame.png', page.locator('#ab-frame'));
});

await step('pause, resume, priority and cancel from the job list', async () => {
  const jobC = await submitExample({ name: 'browser-long', integrator: 'nee', timeS: 300, seed: 3 });
  console.log(`     job ${jobC}`);
  await waitRowState(jobC, 'running', 60_000);
  const row = jobRow(jobC);
  await row.getByRole('button', { name: /^Pause / }).click();
  await waitRowState(jobC, 'paused', 30_000);
  await row.getByRole('button', { name: /^Resume / }).click();
  await waitRowState(jobC, ['running', 'queued'], 30_000);

  const prio = row.getByLabel(/^Priority of /);
  await prio.fill('7');
  await prio.press('Enter');
  const headers = token ? { Authorization: `Bearer ${token}` } : {};
  const deadline = Date.now() + 10_000;
  let priority;
  while (Date.now() < deadline) {
    const r = await page.request.get(new URL(`/api/jobs/${jobC}`, base).href, { headers });
    priority = (await r.json()).priority;
    if (priority === 7) break;
    await page.waitForTimeout(200);
  }
  check(priority === 7, `the priority change did not reach the server (priority ${priority})`);
  await shot('04-controls.png');

  await row.getByRole('button', { name: /^Cancel / }).click();
  await waitRowState(jobC, 'canceled', 30_000);
  check(await row.getByRole('button', { name: /^Cancel / }).isDisabled(), 'cancel stays enabled on a canceled job');

  // A finished job can be deleted (after a confirmation): its row goes, the server forgets it.
  page.once('dialog', (d) => d.accept());
  await row.getByRole('button', { name: /^Delete / }).click();
  await row.waitFor({ state: 'detached', timeout: 10_000 })
    .catch(() => { throw new Failure('the deleted job stayed in the list'); });
  const gone = await page.request.get(new URL(`/api/jobs/${jobC}`, base).href, { headers });
  check(gone.status() === 404, `the deleted job is still on the server (${gone.status()})`);
});

await step('other scene sources: pasted JSON, a scene file with its assets, a .tar folder', async () => {
  const scenes = fileURLToPath(new URL('../../scenes/', import.meta.url));
  const quick = { integrator: 'nee', spp: 4, size: 16 };
  // Paste: start from a built-in scene's JSON (GET /api/scenes/{name}) and submit it inline.
  await page.getByLabel('Example', { exact: true }).check();
  await page.getByLabel('Example scene').selectOption('furnace');
  await page.getByLabel('Paste JSON').check();
  await page.getByRole('button', { name: 'Start from the selected example' }).click();
  await page.waitForFunction(() => document.querySelector('#scene-json').value.includes('"camera"'), null, { timeout: 10_000 })
    .catch(() => { throw new Failure('"Start from the selected example" did not load the scene JSON'); });
  const pasted = await submitForm({ ...quick, name: 'browser-pasted' });
  // Upload: the scene file plus the files it references (sent under the paths it uses).
  await page.getByLabel('Upload', { exact: true }).check();
  await page.getByLabel('Scene file (.json)').setInputFiles(join(scenes, 'textured_mesh.json'));
  await page.getByLabel(/^Files it references/).setInputFiles([join(scenes, 'assets/checker.png'), join(scenes, 'assets/uv_sphere.obj')]);
  const uploaded = await submitForm({ ...quick, name: 'browser-uploaded' });
  // Folder: the same scene as a .tar with scene.json at its root.
  const archive = join(outDir, 'textured_mesh.tar');
  writeFileSync(archive, tar([
    { name: 'scene.json', data: readFileSync(join(scenes, 'textured_mesh.json')) },
    { name: 'assets/checker.png', data: readFileSync(join(scenes, 'assets/checker.png')) },
    { name: 'assets/uv_sphere.obj', data: readFileSync(join(scenes, 'assets/uv_sphere.obj')) },
  ]));
  await page.getByLabel('Folder (.zip/.tar)').check();
  await page.getByLabel('Scene folder as .zip or .tar').setInputFiles(archive);
  const folder = await submitForm({ ...quick, name: 'browser-tar' });
  console.log(`     jobs ${pasted} (pasted), ${uploaded} (uploaded), ${folder} (.tar)`);
  for (const id of [pasted, uploaded, folder]) await waitRowState(id, 'done');
  await page.waitForFunction((id) => {
    const img = document.querySelector('#view-image');
    return img.dataset.job === id && img.naturalWidth === 16;
  }, folder, { timeout: 20_000 }).catch(() => { throw new Failure('the uploaded scene\'s image did not show'); });
  await shot('05-uploads.png');
  await page.getByLabel('Example', { exact: true }).check();
});

await step('every integrator is offered, with options as JSON', async () => {
  const offered = await page.getByLabel('Integrator', { exact: true }).locator('option').evaluateAll((os) => os.map((o) => o.value));
  for (const name of ['pt', 'nee', 'bdpt', 'whitted', 'deferred', 'vct', 'auto']) {
    check(offered.includes(name), `the integrator list lacks ${name} (has ${offered.join(', ')})`);
  }
  // Bad options are refused in the page, naming the field.
  await page.getByLabel('Example', { exact: true }).check();
  await page.getByLabel('Example scene').selectOption('cornell');
  await page.getByLabel('Integrator options (JSON, optional)').fill('{resolution: 64');
  await page.getByLabel('Integrator', { exact: true }).selectOption('vct');
  await page.getByLabel('Height').press('Enter');
  await page.waitForFunction(() => /Integrator options/.test(document.querySelector('#submit-error').textContent), null, { timeout: 5_000 })
    .catch(() => { throw new Failure('invalid integrator options were not reported'); });
  // vct with a small volume: the options reach the job.
  await page.getByLabel('Integrator options (JSON, optional)').fill('{"resolution": 64, "cones": 4}');
  const id = await submitExample({ name: 'browser-vct', integrator: 'vct', spp: 2, size: 16 });
  await waitRowState(id, 'done', 60_000);
  const headers = token ? { Authorization: `Bearer ${token}` } : {};
  const res = await page.request.get(new URL(`/api/jobs/${id}`, base).href, { headers });
  const job = JSON.stringify(await res.json());
  check(/"type":"vct"/.test(job) && /"resolution":64/.test(job) && /"cones":4/.test(job),
    `the vct job does not carry its options: ${job.slice(0, 400)}`);
  await page.getByLabel('Integrator options (JSON, optional)').fill('');
  // auto: the pilot's choice shows in the job view (from the `auto` event or stats.auto).
  const autoId = await submitExample({ name: 'browser-auto', integrator: 'auto', spp: 32, size: 16 });
  await waitRowState(autoId, 'done', 120_000);
  await page.waitForFunction(() => {
    const dd = document.querySelector('#stat-auto');
    return !document.querySelector('#stat-auto-row').hidden && ['pt', 'nee', 'bdpt'].includes(dd.dataset.choice);
  }, null, { timeout: 15_000 }).catch(async () => {
    const text = await page.locator('#stat-auto').textContent();
    throw new Failure(`the auto job's choice is not shown (stat: ${text})`);
  });
});

await step('the state filter lists only done jobs', async () => {
  await page.getByLabel('Show jobs in state').selectOption('done');
  await page.waitForFunction(() => {
    const rows = [...document.querySelectorAll('#job-list li')];
    return rows.length >= 2 && rows.every((li) => li.dataset.state === 'done');
  }, null, { timeout: 15_000 }).catch(() => { throw new Failure('filtering by state=done did not list only the done jobs'); });
  await page.getByLabel('Show jobs in state').selectOption('');
});

/** The job's stored progress events (SSE replayed from the start; the stream ends after done). */
async function progressEvents(id) {
  const headers = { Accept: 'text/event-stream', 'Last-Event-ID': '0', ...(token ? { Authorization: `Bearer ${token}` } : {}) };
  const res = await page.request.get(new URL(`/api/jobs/${id}/events`, base).href, { headers, timeout: 30_000 });
  check(res.ok(), `GET /api/jobs/${id}/events answered ${res.status()}`);
  const out = [];
  for (const block of (await res.text()).split(/\r?\n\r?\n/)) {
    const lines = block.split(/\r?\n/);
    const event = lines.find((l) => l.startsWith('event:'))?.slice(6).trim();
    const data = lines.filter((l) => l.startsWith('data:')).map((l) => l.slice(5).trim()).join('\n');
    if (event === 'progress' && data) out.push(JSON.parse(data));
  }
  return out;
}

/** Bounding boxes of the image and the error chart. */
async function imageAndChartBoxes() {
  const img = await page.locator('#view-image').boundingBox();
  const chart = await page.locator('#metrics-panel').boundingBox();
  check(img && chart, `image box ${JSON.stringify(img)}, chart box ${JSON.stringify(chart)}`);
  return { img, chart };
}

await step('a job with a reference plots its error live beside the image', async () => {
  // The selected job (the .tar upload) has no reference: no reference curve (the chart shows the
  // estimated error alone, dashed, once a progress event carried it).
  check(await page.locator('#metrics-line').count() === 0, 'a reference curve shows for a job without a reference');
  // A second render of the Cornell box measured against job A (same size), chosen in the form.
  await page.getByLabel(/^Reference job/).selectOption(jobA);
  const jobR = await submitExample({ name: 'browser-with-reference', integrator: 'nee', timeS: 5, seed: 5 });
  await page.getByLabel(/^Reference job/).selectOption('');
  console.log(`     job ${jobR} (reference: job ${jobA})`);
  await page.locator('#metrics-panel').waitFor({ state: 'visible', timeout: 30_000 })
    .catch(() => { throw new Failure('the error chart did not appear for a job with a reference'); });
  // Live: a polyline with at least two points while the job renders (or once it ended).
  await page.waitForFunction(() => {
    const line = document.querySelector('#metrics-line');
    return line && line.points.numberOfItems >= 2;
  }, null, { timeout: RENDER_TIMEOUT, polling: 100 })
    .catch(async () => { throw new Failure(`the chart has ${await page.locator('#metrics-chart').getAttribute('data-points')} point(s), expected ≥ 2`); });
  const liveState = await rowState(jobR);
  console.log(`     ≥ 2 points plotted while the job was ${liveState}`);
  await page.waitForFunction(() => document.querySelector('#view-image').naturalWidth > 0, null, { timeout: 20_000 });
  const { img, chart } = await imageAndChartBoxes();
  console.log(`     image at x ${img.x.toFixed(0)}–${(img.x + img.width).toFixed(0)}, chart at x ${chart.x.toFixed(0)}–${(chart.x + chart.width).toFixed(0)} (viewport 1360 px)`);
  check(chart.x >= img.x + img.width - 1, `the chart is not to the right of the image: image ${JSON.stringify(img)}, chart ${JSON.stringify(chart)}`);
  check(chart.y < img.y + img.height && chart.y + chart.height > img.y, `the chart is not beside the image (no vertical overlap): image ${JSON.stringify(img)}, chart ${JSON.stringify(chart)}`);
  check(img.width >= 4 * SIZE, `the image shrank to ${img.width} px next to the chart`);

  await waitRowState(jobR, 'done');
  await page.waitForTimeout(1500); // the final progress event and the job JSON
  const events = (await progressEvents(jobR)).filter((p) => p.metrics);
  const rel = events.map((p) => p.metrics.rel_mse);
  console.log(`     ${events.length} progress events with metrics; relMSE ${rel.map((v) => v.toExponential(2)).join(', ')}`);
  check(events.length >= 2, `only ${events.length} progress event(s) carried metrics`);
  check(rel.every((v) => Number.isFinite(v) && v > 0), `relMSE values not finite and positive: ${rel.join(', ')}`);
  const points = await page.locator('#metrics-line').evaluate((l) => [...Array(l.points.numberOfItems).keys()].map((i) => [l.points.getItem(i).x, l.points.getItem(i).y]));
  check(points.length >= 2, `the final chart has ${points.length} point(s)`);
  check(points.every(([x, y]) => Number.isFinite(x) && Number.isFinite(y)), `non-finite chart coordinates: ${JSON.stringify(points)}`);
  for (let i = 1; i < points.length; i++) check(points[i][0] > points[i - 1][0], `time does not increase along the curve: ${JSON.stringify(points)}`);
  const label = page.locator('#metrics-current');
  const shown = Number(await label.getAttribute('data-value'));
  const text = await label.textContent();
  const last = rel[rel.length - 1];
  console.log(`     last label "${text}" (value ${shown}), last event relMSE ${last}`);
  // Equal up to float parsing: the live event and its stored copy may differ in the last bit.
  check(Math.abs(shown - last) <= 1e-12 * last, `the chart's current value ${shown} is not the last event's relMSE ${last}`);
  const printed = Number(text.replace(/^relMSE\s+/, ''));
  check(Number.isFinite(printed) && Math.abs(printed - last) <= 0.01 * last, `the label "${text}" does not read ${last}`);
  check(/relMSE/.test(await page.locator('#metrics-chart').getAttribute('aria-labelledby').then((ids) => page.evaluate((s) => s.split(' ').map((i) => document.getElementById(i).textContent).join(' '), ids))), 'the chart has no accessible name naming relMSE');
  await shot('06-reference-chart.png');
  await shot('06-reference-view.png', page.locator('.view-main'));

  // FLIP instead of relMSE, then back.
  await page.getByLabel('Error metric').selectOption('flip');
  await page.waitForFunction(() => /^FLIP /.test(document.querySelector('#metrics-current')?.textContent || ''), null, { timeout: 5_000 })
    .catch(() => { throw new Failure('choosing FLIP did not relabel the chart'); });
  const flip = Number(await label.getAttribute('data-value'));
  check(Math.abs(flip - events[events.length - 1].metrics.flip) <= 1e-12 * flip, `FLIP shows ${flip}, the last event says ${events[events.length - 1].metrics.flip}`);
  await page.getByLabel('Error metric').selectOption('rel_mse');

  // Narrow window: the chart wraps below the image.
  await page.setViewportSize({ width: 640, height: 900 });
  await page.waitForTimeout(400);
  const narrow = await imageAndChartBoxes();
  console.log(`     at 640 px: image bottom ${(narrow.img.y + narrow.img.height).toFixed(0)}, chart top ${narrow.chart.y.toFixed(0)}`);
  check(narrow.chart.y >= narrow.img.y + narrow.img.height - 1, `at 640 px the chart is not below the image: image ${JSON.stringify(narrow.img)}, chart ${JSON.stringify(narrow.chart)}`);
  await page.setViewportSize({ width: 1360, height: 900 });

  // The estimate (no reference) is plotted too, dashed, and labelled with the last event's value.
  const estimates = events.map((p) => p.rel_mse_estimate).filter((v) => Number.isFinite(v) && v > 0);
  check(estimates.length >= 1, 'no progress event carried rel_mse_estimate');
  check(await page.locator('#metrics-estimate-line').count() === 1, 'the estimate is not plotted');
  // Another job without a reference shows the estimate alone (no reference curve); reselecting
  // the finished job replays its curve.
  await jobRow(jobA).getByRole('button', { name: /^View / }).click();
  await page.waitForFunction(() => !document.querySelector('#metrics-line')
    && /Estimated/.test(document.querySelector('#metrics-heading').textContent), null, { timeout: 10_000 })
    .catch(() => { throw new Failure('a job without a reference shows a reference curve, or not the estimate heading'); });
  await jobRow(jobR).getByRole('button', { name: /^View / }).click();
  await page.waitForFunction((n) => Number(document.querySelector('#metrics-chart').dataset.points) >= n, Math.min(events.length, 2), { timeout: 20_000 })
    .catch(async () => { throw new Failure(`reselecting the finished job plotted ${await page.locator('#metrics-chart').getAttribute('data-points')} point(s)`); });
});

await step('no page errors and nothing fetched from elsewhere', async () => {
  check(pageErrors.length === 0, `uncaught errors in the page: ${pageErrors.join(' | ')}`);
  check(foreignRequests.length === 0, `the page requested other origins: ${foreignRequests.join(', ')}`);
});

await finish(0);
