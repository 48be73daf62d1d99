#!/usr/bin/env python3
"""Seed 324's closed-form checks (session of 2026-11-29, fifth; bench/RESULTS.md, "Seed 324
solved"), run on the development machine with lavapipe from the repository root:
closed_form324.py MINI_JSON CANDELA. MINI_JSON is variants324.py's "mini" scene (an emitting floor
y = -1, |x|, |z| <= 3; mirrors at z = -3 (m1) and x = 3 (m3); a diffuse wall at x = -3 (m2)) with
its materials cut to m0-m3. Prints candela's pixels (green) against the closed form of the
floor's irradiance on the wall, for several camera positions, for 1 x 1 emitting patches on the
floor, for a point light instead of the floor, and for the wall made an emitter of radiance 1."""
import copy, json, math, subprocess, sys
sys.path.insert(0, "tests/mitsuba")
import audit

mini, cand = json.load(open(sys.argv[1])), sys.argv[2]
RHO_G, LE_G = 0.441, 0.318  # the wall's green reflectance, the floor's green emission


def sub(a, b): return [a[i] - b[i] for i in range(3)]
def add(a, b): return [a[i] + b[i] for i in range(3)]
def mul(a, k): return [x * k for x in a]
def dot(a, b): return sum(a[i] * b[i] for i in range(3))
def cross(a, b): return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
def norm(a): return mul(a, 1 / math.sqrt(dot(a, a)))


def wall_point(s, w, h, px, py):
    """Where pixel (px, py)'s centre ray, reflected by the mirrors, meets the wall m2 (or None)."""
    quads = [(o["material"], o["origin"], o["edge_u"], o["edge_v"]) for o in s["objects"] if o["type"] == "quad"]
    cam = s["camera"]
    f = norm(sub(cam["look_at"], cam["position"])); r = norm(cross(f, [0, 1, 0])); u = cross(r, f)
    th = math.tan(math.radians(cam["fov_y"]) / 2)
    x, y = (px + 0.5) / w * 2 - 1, 1 - (py + 0.5) / h * 2
    o, d = cam["position"], norm(add(f, add(mul(r, x * th * w / h), mul(u, y * th))))
    for _ in range(5):
        best = None
        for m, org, eu, ev in quads:
            n = cross(eu, ev); den = dot(n, d)
            if abs(den) < 1e-12: continue
            t = dot(n, sub(org, o)) / den
            if t <= 1e-6: continue
            p = add(o, mul(d, t)); q = sub(p, org)
            if 0 <= dot(q, eu) / dot(eu, eu) <= 1 and 0 <= dot(q, ev) / dot(ev, ev) <= 1 and (best is None or t < best[0]):
                best = (t, m, p, norm(n))
        if best is None: return None
        _, m, p, n = best
        if m not in ("m1", "m3"): return p if m == "m2" else None
        o, d = p, sub(d, mul(n, 2 * dot(d, n)))
    return None


def irradiance(p, x0=0.0, z0=0.0, size=6.0, y=-1.0, n=200):
    """Irradiance at p (normal +x) from a square emitter of radiance 1 at height y (midpoint sum)."""
    h, tot = size / n, 0.0
    for i in range(n):
        qx = x0 - size / 2 + (i + 0.5) * h
        for j in range(n):
            qz = z0 - size / 2 + (j + 0.5) * h
            dx, dy, dz = qx - p[0], y - p[1], qz - p[2]; r2 = dx * dx + dy * dy + dz * dz
            tot += dx * (-dy) / (r2 * r2)
    return tot * h * h


def render(s, integ="pt", spp=1024):
    json.dump(s, open("/tmp/cf324.json", "w"))
    subprocess.run([cand, "render", "/tmp/cf324.json", "-o", "/tmp/cf324.exr", "--integrator", integ, "--spp", str(spp)],
                   check=True, capture_output=True)
    return audit.read_exr("/tmp/cf324.exr")


PIXELS = [(60, 10), (56, 6), (62, 14), (52, 4)]
# 1. The camera from 2.4 cm outside the wall's plane (the scene's) to 50 cm inside it.
for cx in (-3.0242, -2.95, -2.9, -2.5):
    s = copy.deepcopy(mini); s["camera"]["position"][0] = cx
    w, h, c = render(s)
    for px, py in PIXELS:
        p = wall_point(s, w, h, px, py)
        if p is None: continue
        ana = RHO_G / math.pi * LE_G * irradiance(p)
        print("camera x %.4f pixel %s: closed form %.4f candela %.4f (%.3f)" % (cx, (px, py), ana, c[(py * w + px) * 3 + 1], c[(py * w + px) * 3 + 1] / ana))
# 2. 1 x 1 emitting patches on a dark floor, pixels (59..61, 9..11) against the closed form there.
p = wall_point(mini, 64, 64, 60, 10)
for x0 in (-2.5, 0.0, 2.5):
    for z0 in (-2.5, 0.0, 2.5):
        s = copy.deepcopy(mini)
        s["materials"]["m0"] = {"type": "diffuse", "reflectance": 0.0}
        s["materials"]["pe"] = {"type": "diffuse", "reflectance": 0.0, "emission": [1, 1, 1]}
        s["objects"].append({"type": "quad", "origin": [x0 - 0.5, -0.999, z0 - 0.5], "edge_u": [0, 0, 1], "edge_v": [1, 0, 0], "material": "pe"})
        w, h, c = render(s, "nee", 256)
        got = sum(c[(y * w + x) * 3 + 1] for x in (59, 60, 61) for y in (9, 10, 11)) / 9
        ana = RHO_G / math.pi * irradiance(p, x0, z0, 1.0, -0.999, 100)
        print("patch at x %4.1f z %4.1f: closed form %.5f candela %.5f (%.3f)" % (x0, z0, ana, got, got / ana))
# 3. A point light of intensity 1 at (0, -0.5, 0) instead of the floor: rho/pi cos / r^2.
s = copy.deepcopy(mini)
s["materials"]["m0"] = {"type": "diffuse", "reflectance": 0.0}
s["lights"] = [{"type": "point", "position": [0.0, -0.5, 0.0], "intensity": [1, 1, 1]}]
w, h, c = render(s, "nee", 64)
for px, py in PIXELS:
    q = wall_point(s, w, h, px, py); l = sub([0.0, -0.5, 0.0], q); r2 = dot(l, l)
    ana = RHO_G / math.pi * l[0] / math.sqrt(r2) / r2
    print("point light pixel %s: closed form %.5f candela %.5f (%.3f)" % ((px, py), ana, c[(py * w + px) * 3 + 1], c[(py * w + px) * 3 + 1] / ana))
# 4. The wall an emitter of radiance 1, the floor dark: the mirrors must pass exactly 1.
s = copy.deepcopy(mini)
s["materials"]["m0"] = {"type": "diffuse", "reflectance": 0.5}
s["materials"]["m2"] = {"type": "diffuse", "reflectance": 0.0, "emission": [1, 1, 1]}
w, h, c = render(s, "pt", 64)
print("emitting wall through the mirrors:", [round(c[(py * w + px) * 3 + 1], 4) for px, py in PIXELS])
