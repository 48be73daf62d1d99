"""Writes a many-light scene for `deferred`: a 60×60 floor with a grid of pillars and spheres
(occluders for `shadows: true`), lit by N lights scattered above it (¾ point lights, ¼ spot
lights aimed down), each of intensity I_total/N times a random colour in [0.5, 1.5]³. With the
total fixed, a light's influence radius sqrt(I/cutoff) shrinks as 1/sqrt(N) while the light
density grows as N, so the expected number of lights per pixel, π·I_total/(cutoff·area), is the
same for every N (≈ 87 at the default cutoff 1e-3 and I_total = 100): the benchmark then measures
how culling scales with the light count, not a changing workload. Deterministic for a given
--seed. Python standard library only.

usage: python3 bench/make_many_lights.py N OUT.json [--total 100] [--seed 1]
                                         [--width 1920 --height 1080] [--spp 16]
"""
import argparse
import json
import random
import sys


def scene(n, total, seed, width, height, spp):
    rnd = random.Random(seed)
    half = 30.0
    objects = [
        {"type": "quad", "origin": [-half, 0, -half], "edge_u": [0, 0, 2 * half],
         "edge_v": [2 * half, 0, 0], "material": "floor"},
    ]
    # Pillars on a 6 m grid and a sphere between each pair.
    for i in range(-4, 5):
        for j in range(-4, 5):
            x, z = 6.0 * i, 6.0 * j
            if (i + j) % 2 == 0:
                objects.append({"type": "box", "min": [x - 0.4, 0, z - 0.4],
                                "max": [x + 0.4, 2.5, z + 0.4], "material": "pillar"})
            else:
                objects.append({"type": "sphere", "center": [x, 0.8, z], "radius": 0.8,
                                "material": "ball" if (i * j) % 3 else "metal"})
    each = total / n
    lights = []
    for k in range(n):
        x, z = rnd.uniform(-half + 1, half - 1), rnd.uniform(-half + 1, half - 1)
        y = rnd.uniform(0.3, 3.0)
        c = [round(each * rnd.uniform(0.5, 1.5), 9) for _ in range(3)]
        if k % 4 == 3:
            lights.append({"type": "spot", "position": [x, y, z],
                           "look_at": [x + rnd.uniform(-1, 1), 0, z + rnd.uniform(-1, 1)],
                           "intensity": c, "cutoff_angle": rnd.uniform(30, 60)})
        else:
            lights.append({"type": "point", "position": [x, y, z], "intensity": c})
    return {
        "version": 1,
        "camera": {"position": [0, 18, 34], "look_at": [0, 0, -4], "fov_y": 50},
        "film": {"width": width, "height": height, "exposure": 3, "tonemap": "aces"},
        "materials": {
            "floor": {"type": "diffuse", "reflectance": [0.6, 0.6, 0.6]},
            "pillar": {"type": "diffuse", "reflectance": [0.7, 0.65, 0.55]},
            "ball": {"type": "principled", "base_color": [0.3, 0.5, 0.8], "roughness": 0.35},
            "metal": {"type": "conductor", "reflectance": [0.95, 0.8, 0.5], "roughness": 0.3},
        },
        "objects": objects,
        "lights": lights,
        "render": {"integrator": "deferred", "max_depth": 2, "spp": spp},
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("n", type=int, help="number of lights (>= 1)")
    ap.add_argument("out", help="scene file to write")
    ap.add_argument("--total", type=float, default=100.0, help="summed intensity, W/sr")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--width", type=int, default=1920)
    ap.add_argument("--height", type=int, default=1080)
    ap.add_argument("--spp", type=int, default=16)
    a = ap.parse_args()
    if a.n < 1:
        sys.exit("n: must be at least 1")
    if not a.total > 0:
        sys.exit("--total: must be positive")
    with open(a.out, "w") as f:
        json.dump(scene(a.n, a.total, a.seed, a.width, a.height, a.spp), f, separators=(",", ":"))


if __name__ == "__main__":
    main()
