"""Writes a Cornell box holding a finely tessellated, bumpy sphere of about N triangles (binary
PLY) into a folder, for benchmarking traversal on millions of triangles without committing a
large file.

usage: python3 bench/make_big_scene.py OUT_DIR [--triangles 2000000]
"""
import argparse
import json
import math
import os
import struct
import sys


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--triangles", type=int, default=2_000_000)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    # A UV sphere with nu = 2 nv segments has about 2·nu·nv = 4 nv² triangles.
    nv = max(4, int(math.sqrt(a.triangles / 4)))
    nu = 2 * nv
    verts = []
    for j in range(nv + 1):
        th = math.pi * j / nv
        for i in range(nu + 1):
            ph = 2 * math.pi * i / nu
            r = 0.35 * (1 + 0.03 * math.sin(9 * th) * math.sin(11 * ph))
            verts.append((r * math.sin(th) * math.cos(ph), r * math.cos(th) - 0.55, r * math.sin(th) * math.sin(ph) + 0.1))
    faces = []
    for j in range(nv):
        for i in range(nu):
            a0 = j * (nu + 1) + i
            b0, c0, d0 = a0 + 1, a0 + nu + 2, a0 + nu + 1
            if j != 0:
                faces.append((a0, b0, c0))
            if j != nv - 1:
                faces.append((a0, c0, d0))
    path = os.path.join(a.out, "bumpy.ply")
    with open(path, "wb") as f:
        f.write(("ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
                 "property float z\nelement face %d\nproperty list uchar int vertex_indices\nend_header\n"
                 % (len(verts), len(faces))).encode())
        f.write(b"".join(struct.pack("<3f", *v) for v in verts))
        f.write(b"".join(struct.pack("<B3i", 3, *t) for t in faces))
    here = os.path.dirname(os.path.abspath(__file__))
    scene = json.load(open(os.path.join(here, "..", "scenes", "cornell.json")))
    scene["objects"] = scene["objects"][:6] + [{"type": "mesh", "file": "bumpy.ply", "material": "white", "smooth": False}]
    json.dump(scene, open(os.path.join(a.out, "big.json"), "w"), indent=2)
    print(json.dumps({"triangles": len(faces), "vertices": len(verts), "scene": os.path.join(a.out, "big.json")}))


if __name__ == "__main__":
    sys.exit(main())
