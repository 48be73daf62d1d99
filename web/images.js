// candela web viewer: image loading (blobs with the token, coalesced, swapped once decoded) and
// sizing (crisp integer upscaling).

import { authHeaders, noteUnauthorized, toApiError } from './api.js';

// ---------------------------------------------------------------------------------------------
// Image loading: PNGs are fetched as blobs (so the token can be sent), requests for one <img>
// coalesce (only the newest pending request runs after the one in flight), and the element
// swaps to the new image only once it has decoded, so it never flickers.
// ---------------------------------------------------------------------------------------------

export class ImageSlot {
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
export function availHeight() {
  return Math.max(240, Math.min(window.innerHeight - 260, 1400));
}

/** Sizes an image box to fit `avail`: integer upscaling (crisp pixels) or smooth downscaling. */
export function fitBox(natW, natH, availW, availH) {
  if (!natW || !natH || availW <= 0 || availH <= 0) return { w: natW, h: natH, pixelated: false };
  const s = Math.min(availW / natW, availH / natH);
  const scale = s >= 1 ? Math.max(1, Math.floor(s)) : s;
  return { w: Math.round(natW * scale), h: Math.round(natH * scale), pixelated: scale > 1 };
}
