#!/usr/bin/env python3
"""Audit candela against Mitsuba 3 on random scenes (random_scene.py --mitsuba).

    python3 tests/mitsuba/audit.py --candela BIN --seeds 0:40 --out DIR
        [--size 32] [--spp 1024] [--mitsuba-spp 2048] [--variant scalar_rgb|llvm_ad_rgb|cuda_ad_rgb]
        [--integrators nee,pt,bdpt]

For each seed: the scene, two Mitsuba renders (`path`, seeds 1 and 2) and two candela renders per
integrator (seeds 11 and 12), compared with criteria close to tests/src/lib.rs
`assert_matches_mitsuba`'s: relMSE after 4×4 block averaging below 3× the seed-to-seed noise plus
2e-4, with all four images scaled so that the first Mitsuba image's mean is 0.3 (relMSE's 0.01
floor would hide a dark scene); mean FLIP (unscaled) below 0.1, or where the noise alone gives
more (FLIP between the two seeds of either renderer, `flip_noise`), below 1.5× that (the Rust check
keeps a strict 0.1: its scenes are quieter); per-channel means within 2%, or
within 5 standard errors of the two renderers' means where that is wider (estimated from each
pair's seed-to-seed differences over 4×4 blocks; the Rust check keeps a strict 2%). Comparisons
the renderers do not share are skipped: pt with delta lights (pt cannot reach them), bdpt with
delta lights and smooth specular surfaces (caustics only bdpt can reach). One JSON line per
comparison on stdout (and DIR/audit.jsonl), then a summary; exit status 1 when any failed.

`export` in --integrators audits candela's Mitsuba exporter instead of a candela integrator: the
scene written by `candela convert scene.json scene.xml`, rendered by Mitsuba (tests/mitsuba/
render_xml.py, seeds 3 and 4), is compared as above with the reference translator's renders (two
independent translations, one renderer). A scene the exporter refuses as inexpressible is
recorded as skipped, with its reason.
"""
import argparse
import json
import math
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))


def read_exr(path):
    import mitsuba as mi
    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    b = mi.Bitmap(path).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False)
    h, w = b.height(), b.width()
    flat = list(mi.TensorXf(b).array)
    return w, h, flat


def blocks(img, k=4):
    w, h, px = img
    bw, bh = w // k, h // k
    out = []
    for by in range(bh):
        for bx in range(bw):
            acc = [0.0, 0.0, 0.0]
            for y in range(by * k, by * k + k):
                for x in range(bx * k, bx * k + k):
                    i = 3 * (y * w + x)
                    for c in range(3):
                        acc[c] += px[i + c]
            out.append([a / (k * k) for a in acc])
    return out


def rel_mse(a, b):
    """tests' relMSE: mean over pixels and channels of (x − r)² / (r² + 0.01)."""
    n, s = 0, 0.0
    for p, q in zip(a, b):
        for c in range(3):
            s += (p[c] - q[c]) ** 2 / (q[c] ** 2 + 0.01)
            n += 1
    return s / n


def means(bl):
    return [sum(p[c] for p in bl) / len(bl) for c in range(3)]


def mean_stderr(b1, b2):
    """Standard error of one render's mean, from the blocks of two seeds: the difference of a
    block between seeds has twice one render's block variance."""
    n = len(b1)
    return [math.sqrt(sum((p[c] - q[c]) ** 2 for p, q in zip(b1, b2)) / 2) / n for c in range(3)]


def scaled(bl, k):
    return [[k * x for x in p] for p in bl]


def flip(candela, a, b):
    """Mean FLIP between two EXR files (`candela compare`)."""
    out = subprocess.run([candela, "compare", a, b, "--json"], capture_output=True, text=True,
                         check=True)
    return json.loads(out.stdout)["metrics"]["flip"]


def compare(candela, c, m, names):
    """c, m: two seeds' images of each renderer; names: their EXR files, (c1, c2), (m1, m2)."""
    (c1, c2), (m1, m2) = c, m
    bc1, bc2, bm1, bm2 = blocks(c1), blocks(c2), blocks(m1), blocks(m2)
    # Exposure: every image scaled so that the reference's mean is 0.3 (relMSE's 0.01 floor
    # would otherwise hide any difference in a dark scene).
    k = 0.3 / max(sum(means(bm1)) / 3, 1e-12)
    bc1, bc2, bm1, bm2 = (scaled(b, k) for b in (bc1, bc2, bm1, bm2))
    blocked = rel_mse(bc1, bm1)
    noise = rel_mse(bc1, bc2) / 2 + rel_mse(bm1, bm2) / 2
    mc, mm = means(bc1), means(bm1)
    se = [math.hypot(a, b) for a, b in zip(mean_stderr(bc1, bc2), mean_stderr(bm1, bm2))]
    (nc1, nc2), (nm1, nm2) = names
    f = flip(candela, nc1, nm1)
    # The FLIP two renders of the same image have from their noise alone.
    flip_noise = max(flip(candela, nc1, nc2), flip(candela, nm1, nm2))
    fails = []
    for ch in range(3):
        if mm[ch] > 1e-3 and abs(mc[ch] - mm[ch]) > max(0.02 * mm[ch], 5 * se[ch]):
            fails.append(f"mean[{ch}] {mc[ch]:.4f} vs {mm[ch]:.4f} (stderr {se[ch]:.4f})")
    if blocked >= 3 * noise + 2e-4:
        fails.append(f"block relMSE {blocked:.3e} vs noise {noise:.3e}")
    if f >= max(0.1, 1.5 * flip_noise):
        fails.append(f"FLIP {f:.3f} (noise {flip_noise:.3f})")
    return {"exposure": k, "block_rel_mse": blocked, "noise": noise, "flip": f,
            "flip_noise": flip_noise, "mean_candela": mc, "mean_mitsuba": mm, "stderr": se,
            "fails": fails}


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {r.returncode}: {r.stderr.strip()[-800:]}")
    return r.stdout


def rendered(a, scene, d, integ):
    """candela's two renders (EXR path, image) of `scene` with integrator `integ`."""
    out = []
    for s in (11, 12):
        p = os.path.join(d, f"{integ}{s}.exr")
        run([a.candela, "render", scene, "-o", p, "--integrator", integ, "--spp", str(a.spp),
             "--seed", str(s)])
        out.append((p, read_exr(p)))
    return out


def exported(a, scene, d):
    """Mitsuba's two renders (EXR path, image) of `candela convert`'s XML of `scene`, or why the
    exporter refused it (exit 1 naming what Mitsuba cannot express)."""
    xml = os.path.join(d, "exported.xml")
    r = subprocess.run([a.candela, "convert", scene, xml], capture_output=True, text=True)
    if r.returncode != 0:
        if "cannot express this exactly" in r.stderr:
            return r.stderr.strip()[-300:]
        raise RuntimeError(f"candela convert: exit {r.returncode}: {r.stderr.strip()[-800:]}")
    return mitsuba_pair(a, "render_xml.py", xml, d, "export", (3, 4))


def mitsuba_pair(a, script, scene, d, name, seeds):
    """Mitsuba's renders (EXR path, image) of `scene` by tests/mitsuba/`script`, one per seed."""
    out = []
    for s in seeds:
        p = os.path.join(d, f"{name}{s}.exr")
        run([sys.executable, os.path.join(HERE, script), scene, p, "--spp", str(a.mitsuba_spp),
             "--seed", str(s), "--variant", a.variant])
        out.append((p, read_exr(p)))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--candela", required=True)
    ap.add_argument("--seeds", default="0:20", help="FIRST:END (END excluded)")
    ap.add_argument("--out", required=True)
    ap.add_argument("--size", type=int, default=32)
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--mitsuba-spp", type=int, default=2048)
    ap.add_argument("--variant", default="scalar_rgb")
    ap.add_argument("--integrators", default="nee,pt,bdpt")
    a = ap.parse_args()
    first, end = (int(x) for x in a.seeds.split(":"))
    os.makedirs(a.out, exist_ok=True)
    log = open(os.path.join(a.out, "audit.jsonl"), "w")
    failed, total = [], 0
    for seed in range(first, end):
        d = os.path.join(a.out, f"s{seed}")
        facts = json.loads(run([sys.executable, os.path.join(HERE, "random_scene.py"), str(seed),
                                d, "--size", str(a.size), "--mitsuba"]))
        scene = os.path.join(d, "scene.json")
        try:
            mi = mitsuba_pair(a, "render_reference.py", scene, d, "mitsuba", (1, 2))
        except RuntimeError as e:
            total += 1
            rec = {"seed": seed, "error": f"mitsuba: {e}"}
            print(json.dumps(rec), flush=True)
            log.write(json.dumps(rec) + "\n")
            failed.append(rec)
            continue
        for integ in a.integrators.split(","):
            skip = (integ == "pt" and facts["delta_lights"]) or (
                integ == "bdpt" and facts["delta_lights"] and facts["delta_surfaces"])
            if skip:
                continue
            rec = {"seed": seed, "integrator": integ, "features": facts["features"]}
            try:
                cs = exported(a, scene, d) if integ == "export" else rendered(a, scene, d, integ)
                if isinstance(cs, str):
                    rec["skipped"] = cs
                else:
                    rec.update(compare(a.candela, [c[1] for c in cs], [m[1] for m in mi],
                                       ([c[0] for c in cs], [m[0] for m in mi])))
            except RuntimeError as e:
                rec["fails"] = [str(e)]
            print(json.dumps(rec), flush=True)
            log.write(json.dumps(rec) + "\n")
            log.flush()
            if "skipped" not in rec:
                total += 1
            if rec.get("fails"):
                failed.append(rec)
    print(f"{total - len(failed)} of {total} comparisons agree; failed: "
          + ", ".join(f"{r['seed']}/{r.get('integrator', 'mitsuba')}" for r in failed))
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
