#!/usr/bin/env python3
"""Which part of a random scene makes candela and Mitsuba differ: variants of one scene, each
compared as audit.py does (block relMSE against noise, means). bisect.py SEED CANDELA OUT SPP
(Mitsuba variant: $VARIANT, default cuda_ad_rgb; $ONLY: the variants to run, by name)"""
import copy, json, os, subprocess, sys
sys.path.insert(0, "tests/mitsuba")
import audit
seed, cand, out, spp = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
d = os.path.join(out, f"s{seed}")
subprocess.run([sys.executable, "tests/mitsuba/random_scene.py", seed, d, "--size", "64", "--mitsuba"], check=True, capture_output=True)
base = json.load(open(os.path.join(d, "scene.json")))
def var(name, f):
    v = copy.deepcopy(base); f(v); return name, v
def diffuse(*ms):
    def f(v):
        for m in ms: v["materials"][m] = {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}
    return f
def png_upsampled(src, dst, k):
    """An 8-bit RGB PNG (rows of filter type 0, as random_scene.py's assets) k× larger, each
    texel repeated: the same pattern, its bilinear blends k× narrower in uv."""
    import struct, zlib
    d = open(src, "rb").read()
    w, h = struct.unpack(">II", d[16:24]); assert d[24:26] == bytes([8, 2]), "8-bit RGB only"
    i, idat = 8, b""
    while i < len(d):
        n = struct.unpack(">I", d[i:i + 4])[0]
        if d[i + 4:i + 8] == b"IDAT": idat += d[i + 8:i + 8 + n]
        i += 12 + n
    raw = zlib.decompress(idat); rows = [raw[y * (3 * w + 1):(y + 1) * (3 * w + 1)] for y in range(h)]
    assert all(r[0] == 0 for r in rows), "filter type 0 only"
    big = b"".join(b"\0" + b"".join(r[1 + 3 * x:4 + 3 * x] * k for x in range(w)) for r in rows for _ in range(k))
    chunk = lambda t, b: struct.pack(">I", len(b)) + t + b + struct.pack(">I", zlib.crc32(t + b))
    open(dst, "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w * k, h * k, 8, 2, 0, 0, 0))
                          + chunk(b"IDAT", zlib.compress(big)) + chunk(b"IEND", b""))
mats = base["materials"]
vs = [("base", base)]
# Textured roughness: Mitsuba's derived alpha texture interpolates roughness² where candela squares
# the interpolated roughness; with the texture 4× finer (same pattern) the blends shrink 4×.
for m, mat in mats.items():
    r = mat.get("roughness")
    if isinstance(r, dict) and "texture" in r:
        fine = os.path.join(d, "assets", "fine4_" + os.path.basename(r["texture"]))
        png_upsampled(os.path.join(d, r["texture"]), fine, 4)
        vs.append(var(f"{m}_roughness_fine4", lambda v, m=m, f=fine: v["materials"][m]["roughness"].__setitem__("texture", os.path.relpath(f, d))))
        vs.append(var(f"{m}_roughness_const", lambda v, m=m: v["materials"][m].__setitem__("roughness", 0.3)))
for m, mat in mats.items():
    if mat.get("alpha_mask"): vs.append(var(f"{m}_no_alpha", lambda v, m=m: v["materials"][m].pop("alpha_mask")))
    if mat["type"] in ("dielectric", "principled", "conductor"): vs.append(var(f"{m}_diffuse", diffuse(m)))
    for key in ("anisotropic", "anisotropy"):  # principled's and the conductor's
        if mat.get(key): vs.append(var(f"{m}_iso", lambda v, m=m, key=key: v["materials"][m].__setitem__(key, 0.0)))
    if mat.get("two_sided") is False: vs.append(var(f"{m}_two_sided", lambda v, m=m: v["materials"][m].pop("two_sided")))
if base.get("lights"): vs.append(var("no_delta_lights", lambda v: v.pop("lights")))
# Boxes resting on the floor share its plane (the generator's min y = -1): lifted by 1 cm.
def lift(v):
    for o in v["objects"]:
        if o["type"] == "box" and o["min"][1] == -1: o["min"][1] = -0.99
if any(o["type"] == "box" and o["min"][1] == -1 for o in base["objects"]): vs.append(var("boxes_lifted", lift))
if os.environ.get("ONLY"):  # a space-separated subset of the variants' names
    vs = [x for x in vs if x[0] in os.environ["ONLY"].split()]
for name, v in vs:
    p = os.path.join(d, f"{name}.json"); json.dump(v, open(p, "w"))
    mi, cs = [], []
    for s in (1, 2):
        o = os.path.join(d, f"{name}_m{s}.exr")
        subprocess.run([sys.executable, "tests/mitsuba/render_reference.py", p, o, "--spp", spp, "--seed", str(s), "--variant", os.environ.get("VARIANT", "cuda_ad_rgb")], check=True, capture_output=True)
        mi.append(o)
        o = os.path.join(d, f"{name}_c{s}.exr")
        subprocess.run([cand, "render", p, "-o", o, "--integrator", "nee", "--spp", spp, "--seed", str(10 + s)], check=True, capture_output=True)
        cs.append(o)
    r = audit.compare(cand, [audit.read_exr(x) for x in cs], [audit.read_exr(x) for x in mi], (cs, mi))
    print(name, "blk %.2e noise %.2e ratio %.1f" % (r["block_rel_mse"], r["noise"], r["block_rel_mse"] / r["noise"]),
          [round(x, 4) for x in r["mean_candela"]], [round(x, 4) for x in r["mean_mitsuba"]], flush=True)
    if name == "base":
        bc = [[(a + b) / 2 for a, b in zip(p, q)] for p, q in zip(audit.blocks(audit.read_exr(cs[0])), audit.blocks(audit.read_exr(cs[1])))]
        bm = [[(a + b) / 2 for a, b in zip(p, q)] for p, q in zip(audit.blocks(audit.read_exr(mi[0])), audit.blocks(audit.read_exr(mi[1])))]
        bn = [[(a - b) for a, b in zip(p, q)] for p, q in zip(audit.blocks(audit.read_exr(mi[0])), audit.blocks(audit.read_exr(mi[1])))]
        err = sorted(((sum((x - y) ** 2 for x, y in zip(p, q)) / (sum(y * y for y in q) + 1e-4), i, [round(x, 4) for x in p], [round(y, 4) for y in q], [round(z, 4) for z in n]) for i, (p, q, n) in enumerate(zip(bc, bm, bn))), reverse=True)
        for e in err[:8]:
            print("  block", e[1] % 16, e[1] // 16, "rel %.3f" % e[0], "candela", e[2], "mitsuba", e[3], "m1-m2", e[4])
