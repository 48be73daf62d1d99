"""Writes a many-light scene whose lights are the N emissive triangles of one mesh (issue 14's
many-light sampling at mesh scale), or, with --single, the same scene with all that power in one
emissive triangle. A 20×20 m floor with a grid of boxes (occluders) under a layer of N small
triangles scattered at random over 18×18 m between heights 3 and 6 m, each facing down, of area
--area/N and radiance --radiance: the total emitted power (radiance · π · total area) is the same
for every N and for --single (one triangle of area --area at the centre, 4.5 m up, facing down).
With --panel the N triangles instead tile one square of area --area at the single light's centre
and height (a tessellated area light; N even; N = 2 is the square as one quad: the --single
triangle has the same area, power and centre, not the same shape). Deterministic for a given
--seed. Python standard library only.

usage: python3 bench/make_mesh_lights.py N OUT.json [--single | --panel] [--area 4]
                                         [--radiance 20] [--seed 1] [--width 1280 --height 720]
                                         [--spp 16]
"""
import argparse
import json
import math
import random
import sys


def down_triangle(cx, y, cz, area, angle):
    """An equilateral triangle of `area` centred at (cx, y, cz), rotated by `angle` about the
    vertical, wound so that its front face (e1 × e2) points down."""
    side = math.sqrt(4.0 * area / math.sqrt(3.0))
    r = side / math.sqrt(3.0)  # circumradius
    pts = []
    for k in range(3):
        a = angle + 2.0 * math.pi * k / 3.0
        pts.append([cx + r * math.cos(a), y, cz + r * math.sin(a)])
    # Counter-clockwise seen from above (angles increasing from +x towards +z) gives e1 × e2
    # along −y.
    return pts


def panel_triangles(n, area, y):
    """n (even) triangles tiling a square of `area` centred at (0, y, 0), facing down: rows × cols
    cells of two triangles, rows the largest divisor of n/2 not above its square root."""
    cells = n // 2
    rows = max(r for r in range(1, int(math.isqrt(cells)) + 1) if cells % r == 0)
    cols = cells // rows
    side = math.sqrt(area)
    dx, dz = side / cols, side / rows
    tris = []
    for r in range(rows):
        for c in range(cols):
            x0, z0 = -side / 2 + c * dx, -side / 2 + r * dz
            a, b = [x0, y, z0], [x0 + dx, y, z0]
            cc, d = [x0 + dx, y, z0 + dz], [x0, y, z0 + dz]
            # (b − a) × (c − a) and (c − a) × (d − a) point along −y.
            tris.append([a, b, cc])
            tris.append([a, cc, d])
    return tris


def scene(n, single, panel, area, radiance, seed, width, height, spp):
    rnd = random.Random(seed)
    half = 10.0
    objects = [
        {"type": "quad", "origin": [-half, 0, -half], "edge_u": [0, 0, 2 * half],
         "edge_v": [2 * half, 0, 0], "material": "floor"},
    ]
    for i in range(-2, 3):
        for j in range(-2, 3):
            x, z = 4.0 * i, 4.0 * j
            objects.append({"type": "box", "min": [x - 0.5, 0, z - 0.5],
                            "max": [x + 0.5, 1.0 + 0.25 * ((i + j) % 3), z + 0.5],
                            "material": "box"})
    positions = []
    indices = []
    if single:
        tris = [down_triangle(0.0, 4.5, 0.0, area, 0.0)]
    elif panel:
        tris = panel_triangles(n, area, 4.5)
    else:
        each = area / n
        tris = [down_triangle(rnd.uniform(-9, 9), rnd.uniform(3, 6), rnd.uniform(-9, 9), each,
                              rnd.uniform(0, 2 * math.pi)) for _ in range(n)]
    for t in tris:
        base = len(positions)
        positions.extend([[round(c, 6) for c in p] for p in t])
        indices.extend([base, base + 1, base + 2])
    objects.append({"type": "triangles", "positions": positions, "indices": indices,
                    "material": "emitter"})
    return {
        "version": 1,
        "camera": {"position": [0, 9, 17], "look_at": [0, 0, 0], "fov_y": 55},
        "film": {"width": width, "height": height, "exposure": 0, "tonemap": "aces"},
        "materials": {
            "floor": {"type": "diffuse", "reflectance": [0.6, 0.6, 0.6]},
            "box": {"type": "diffuse", "reflectance": [0.7, 0.5, 0.4]},
            "emitter": {"type": "diffuse", "reflectance": [0, 0, 0],
                        "emission": [radiance, radiance, radiance]},
        },
        "objects": objects,
        "render": {"integrator": "nee", "max_depth": 2, "spp": spp},
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("n", type=int, help="number of emissive triangles (>= 1; ignored with --single)")
    ap.add_argument("out", help="scene file to write")
    ap.add_argument("--single", action="store_true", help="one triangle with all the power")
    ap.add_argument("--panel", action="store_true",
                    help="the N triangles tile one square of the same area at the single light's centre")
    ap.add_argument("--area", type=float, default=4.0, help="total emitting area, m²")
    ap.add_argument("--radiance", type=float, default=20.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--width", type=int, default=1280)
    ap.add_argument("--height", type=int, default=720)
    ap.add_argument("--spp", type=int, default=16)
    a = ap.parse_args()
    if a.n < 1:
        sys.exit("n: must be at least 1")
    if a.panel and (a.single or a.n % 2):
        sys.exit("--panel: needs an even n, and not --single")
    if not (a.area > 0 and a.radiance > 0):
        sys.exit("--area, --radiance: must be positive")
    with open(a.out, "w") as f:
        json.dump(scene(a.n, a.single, a.panel, a.area, a.radiance, a.seed, a.width, a.height, a.spp), f,
                  separators=(",", ":"))


if __name__ == "__main__":
    main()
