"""Candela objects (docs/scene-format.md, "objects") → instantiated Mitsuba 3 shapes.

Each object becomes one Mitsuba shape, instantiated here (so ref_scene.py knows the scene bounds)
with its material's BSDF and, for emissive materials, an `area` emitter. Raises Untranslatable
(exit 2) or SceneError (exit 1).
"""
import json
import os
import struct

import drjit as dr
import mitsuba as mi

from ref_common import (SceneError, Untranslatable, add, check_fields, cross, dot, flat, length,
                        mul, normalize, num, resolve, sub, vec3)
from ref_materials import translate_material

T4 = mi.ScalarTransform4f


def matrix_rows(t):
    m = t.matrix
    return [[float(m[i][j]) for j in range(4)] for i in range(4)]


def object_transform(t, path):
    """`{"matrix": 16 row-major}` or scale → rotate(axis, deg) → translate, in that order."""
    if t is None:
        return T4()
    check_fields(t, path, {"matrix", "scale", "rotate", "translate"})
    if "matrix" in t:
        if len(t) != 1:
            raise SceneError(f"{path}: matrix excludes scale/rotate/translate")
        m = t["matrix"]
        if not isinstance(m, list) or len(m) != 16:
            raise SceneError(f"{path}.matrix: expected 16 numbers")
        m = [num(x, f"{path}.matrix") for x in m]
        return T4([m[0:4], m[4:8], m[8:12], m[12:16]])
    out = T4()
    if "translate" in t:
        out = out.translate(vec3(t["translate"], f"{path}.translate"))
    if "rotate" in t:
        r = t["rotate"]
        check_fields(r, f"{path}.rotate", {"axis", "angle"}, required=("axis", "angle"))
        axis = normalize(vec3(r["axis"], f"{path}.rotate.axis"), f"{path}.rotate.axis")
        out = out.rotate(axis, num(r["angle"], f"{path}.rotate.angle"))
    if "scale" in t:
        s = t["scale"]
        s = vec3(s, f"{path}.scale") if isinstance(s, list) else [num(s, f"{path}.scale")] * 3
        out = out.scale(s)
    return out


def write_ply(fname, pos, idx, normals, uvs):
    """Binary little-endian PLY; uv stored as (u, 1 - v) because Mitsuba's PLY loader keeps v
    as-is and its bitmap puts v = 0 at the top, while candela's inline uvs use the OBJ convention
    (texel row = (1 - v) * height)."""
    props = ["x", "y", "z"] + (["nx", "ny", "nz"] if normals else []) + (["u", "v"] if uvs else [])
    head = ["ply", "format binary_little_endian 1.0", f"element vertex {len(pos)}"]
    head += [f"property float {p}" for p in props]
    head += [f"element face {len(idx)}", "property list uchar int vertex_indices", "end_header"]
    rec = struct.Struct("<" + "f" * len(props))
    with open(fname, "wb") as f:
        f.write(("\n".join(head) + "\n").encode())
        for i, p in enumerate(pos):
            vals = list(p) + (list(normals[i]) if normals else [])
            vals += [uvs[i][0], 1.0 - uvs[i][1]] if uvs else []
            f.write(rec.pack(*vals))
        for t in idx:
            f.write(struct.pack("<B3i", 3, *t))


def mirrors(xf):
    """Whether transform `xf` mirrors (its linear part's determinant is negative)."""
    m = matrix_rows(xf)
    return (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])) < 0


def file_has_normals(fname):
    """Whether a PLY's vertices or an OBJ's faces carry normals (as candela's loaders read them)."""
    with open(fname, "rb") as f:
        if fname.lower().endswith(".ply"):
            for line in f:
                w = line.split()
                if w == [b"end_header"]:
                    return False
                if len(w) == 3 and w[0] == b"property" and w[2] == b"nx":
                    return True
            return False
        for line in f:
            w = line.split()
            if w and w[0] == b"f" and any(len(t.split(b"/")) == 3 and t.split(b"/")[2]
                                          for t in w[1:]):
                return True
    return False


def obj_usemtl(fname):
    """(names used by `usemtl`, whether a face comes before the first usemtl)."""
    names, face_first = [], False
    with open(fname, errors="replace") as f:
        for line in f:
            w = line.split()
            if w and w[0] == "usemtl":
                names.append(w[1] if len(w) > 1 else "")
            elif w and w[0] == "f" and not names:
                face_first = True
    return set(names), face_first


class Shapes:
    """Translates objects; caches one BSDF instance per material."""

    def __init__(self, scene, scene_dir, tmp_dir, tex):
        self.scene, self.dir, self.tmp, self.tex = scene, scene_dir, tmp_dir, tex
        self.materials = {}  # name -> (bsdf instance, emission, uses_mask)
        self.uses_mask = False

    def material(self, name, path):
        if name not in self.materials:
            mats = self.scene.get("materials") or {}
            if not isinstance(mats, dict) or not isinstance(name, str) or name not in mats:
                raise SceneError(f"{path}: no material {name!r}")
            bsdf, em, mask = translate_material(mats[name], f"materials.{name}", self.tex)
            self.materials[name] = (mi.load_dict(bsdf), em, mask)
        return self.materials[name]

    def shape(self, i, o):
        path = f"objects[{i}]"
        if not isinstance(o, dict):
            raise SceneError(f"{path}: expected an object")
        kind = o.get("type")
        known = {"mesh": {"file", "smooth"},
                 "triangles": {"positions", "indices", "normals", "uvs"},
                 "sphere": {"center", "radius", "flip_normals"},
                 "quad": {"origin", "edge_u", "edge_v"}, "box": {"min", "max"}}
        if kind not in known:
            raise Untranslatable(f"{path}.type: unknown object type {kind!r}")
        check_fields(o, path, known[kind] | {"type", "material", "transform"})
        xf = object_transform(o.get("transform"), f"{path}.transform")
        mat = o.get("material")
        if kind == "mesh":
            d, mat = self.mesh(o, path, mat, mirrors(xf))
        elif kind == "triangles":
            d = self.triangles(o, path, i, mirrors(xf))
        elif kind == "sphere":
            d = self.sphere(o, path, xf)
        elif kind == "quad":
            d = self.quad(o, path)
        else:
            lo, hi = vec3(o.get("min"), f"{path}.min"), vec3(o.get("max"), f"{path}.max")
            if any(h <= l for l, h in zip(lo, hi)):
                raise SceneError(f"{path}: max must exceed min on every axis")
            d = {"type": "cube", "to_world": T4().translate(mul(add(lo, hi), 0.5))
                 .scale(mul(sub(hi, lo), 0.5))}
        if kind != "sphere":
            d["to_world"] = xf @ d.get("to_world", T4())
        if mat is None:
            raise SceneError(f"{path}.material: required field missing")
        bsdf, em, mask = self.material(mat, f"{path}.material")
        self.uses_mask |= mask
        d["bsdf"] = bsdf
        if em:
            d["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": em}}
        return mi.load_dict(d)

    def mesh(self, o, path, mat, mirrored):
        full = resolve(self.dir, o.get("file"), f"{path}.file")
        smooth = o.get("smooth", True)
        if not isinstance(smooth, bool):
            raise SceneError(f"{path}.smooth: expected true or false")
        ext = os.path.splitext(full)[1].lower()
        if ext not in (".obj", ".ply"):
            raise Untranslatable(f"{path}.file: unsupported mesh format {ext!r}")
        if ext == ".obj" and mat is None:
            names, face_first = obj_usemtl(full)
            if not names:
                raise SceneError(f"{path}.material: required (the OBJ has no usemtl)")
            if len(names) != 1 or face_first:  # Mitsuba's obj plugin ignores usemtl
                raise Untranslatable(f"{path}: mesh relies on OBJ usemtl ({len(names)} names)")
            mat = names.pop()
        if ext == ".ply" and "texture" in json.dumps((self.scene.get("materials") or {}).get(mat)):
            full = self.ply_flipped_v(full)
        if mirrored and (not smooth or not file_has_normals(full)):
            full, ext = self.reversed(full), ".ply"
        return {"type": ext[1:], "filename": full, "face_normals": not smooth}, mat

    def reversed(self, full):
        """Under a mirroring to_world Mitsuba keeps a mesh's vertex order, so where no vertex
        normals set its front (none, or face_normals) that front is the other side than candela's
        (pbrt's rule, docs/scene-format.md's transform): such a mesh is handed over as a copy with
        its winding reversed."""
        mesh = mi.load_dict({"type": os.path.splitext(full)[1][1:], "filename": full,
                             "face_normals": True})
        params = mi.traverse(mesh)
        f = params["faces"]
        k = dr.arange(dr.scalar.ArrayXu, len(f))
        # Each triangle's second and third indices swapped.
        params["faces"] = dr.gather(type(f), f, dr.select(k % 3 == 1, k + 1,
                                                          dr.select(k % 3 == 2, k - 1, k)))
        params.update()
        out = os.path.join(self.tmp, f"reversed_{len(os.listdir(self.tmp))}.ply")
        mesh.write_ply(out)
        return out

    def ply_flipped_v(self, full):
        """Mitsuba's PLY loader puts v = 0 on a texture's top row, candela's on the bottom row:
        a textured PLY is handed to Mitsuba as a copy with v → 1 - v."""
        mesh = mi.load_dict({"type": "ply", "filename": full})
        params = mi.traverse(mesh)
        uv = params["vertex_texcoords"]
        if len(uv) == 0:
            return full
        k = dr.arange(dr.scalar.ArrayXu, len(uv))
        params["vertex_texcoords"] = dr.select(k % 2 == 1, 1.0 - uv, uv)
        params.update()
        out = os.path.join(self.tmp, f"flipped_{len(os.listdir(self.tmp))}.ply")
        mesh.write_ply(out)
        return out

    def triangles(self, o, path, i, mirrored):
        pos = flat(o.get("positions"), 3, f"{path}.positions")
        idx = [tuple(int(x) for x in t) for t in flat(o.get("indices"), 3, f"{path}.indices")]
        if any(not 0 <= x < len(pos) for t in idx for x in t):
            raise SceneError(f"{path}.indices: index out of range")
        nrm = flat(o["normals"], 3, f"{path}.normals") if "normals" in o else None
        uvs = flat(o["uvs"], 2, f"{path}.uvs") if "uvs" in o else None
        for name, arr in (("normals", nrm), ("uvs", uvs)):
            if arr is not None and len(arr) != len(pos):
                raise SceneError(f"{path}.{name}: one per position expected")
        if mirrored and nrm is None:  # reversed, as a mesh's (Shapes.reversed)
            idx = [(a, c, b) for a, b, c in idx]
        fname = os.path.join(self.tmp, f"triangles_{i}.ply")
        write_ply(fname, pos, idx, nrm, uvs)
        # Without normals: flat shading (geometric normals), not Mitsuba's computed vertex normals.
        return {"type": "ply", "filename": fname, "face_normals": nrm is None}

    def sphere(self, o, path, xf):
        c, r = vec3(o.get("center"), f"{path}.center"), num(o.get("radius"), f"{path}.radius")
        if r <= 0:
            raise SceneError(f"{path}.radius: must be positive")
        m = matrix_rows(xf)
        cols = [[m[0][j], m[1][j], m[2][j]] for j in range(3)]
        k2 = [dot(cols[a], cols[b]) for a in range(3) for b in range(3)]
        s2 = k2[0]
        if any(abs(k2[3 * a + b] - (s2 if a == b else 0)) > 1e-6 * s2 for a in range(3)
               for b in range(3)):
            raise Untranslatable(f"{path}.transform: sphere under non-uniform scale or shear")
        flip = o.get("flip_normals", False)
        if not isinstance(flip, bool):
            raise SceneError(f"{path}.flip_normals: expected true or false")
        return {"type": "sphere", "flip_normals": flip,
                "to_world": xf @ T4().translate(c).scale(r)}

    def quad(self, o, path):
        """Mitsuba's rectangle is [-1,1]² at z = 0 with normal +Z and uv = ((x+1)/2, (y+1)/2):
        map it to origin + s·edge_u + t·edge_v (so uv = (s, t)), normal normalize(eu × ev)."""
        org = vec3(o.get("origin"), f"{path}.origin")
        eu, ev = vec3(o.get("edge_u"), f"{path}.edge_u"), vec3(o.get("edge_v"), f"{path}.edge_v")
        n = cross(eu, ev)
        if length(n) <= 1e-12 * max(length(eu) * length(ev), 1e-300):
            raise SceneError(f"{path}: degenerate quad (parallel edges)")
        n = normalize(n)
        c = add(org, mul(add(eu, ev), 0.5))
        rows = [[eu[k] / 2, ev[k] / 2, n[k], c[k]] for k in range(3)] + [[0, 0, 0, 1]]
        return {"type": "rectangle", "to_world": T4(rows)}
