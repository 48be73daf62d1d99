#!/usr/bin/env python3
"""Random candela scenes for differential audits (tests/tests/random_scenes.rs, audit.py).

    python3 tests/mitsuba/random_scene.py SEED OUT_DIR [--size N] [--mitsuba]

writes OUT_DIR/scene.json (its textures and mesh copied into OUT_DIR/assets) and prints one JSON
line of facts the generator knows independently of candela's loader:
- `features`: the kernel features the scene uses (the names of `FeatureSet`, compile/features.rs),
  derived from what was placed, not from candela's detection;
- `translatable`: whether tests/mitsuba/render_reference.py can express the scene (no phong, no
  instances), so Mitsuba 3 can serve as its reference;
- `delta_lights`, `delta_surfaces`: point/spot/directional lights; smooth conductors or
  dielectrics. pt cannot see delta lights (Mitsuba's `path` can), and light paths from a delta light
  over a smooth surface (caustics) are reached by bdpt but by neither nee nor Mitsuba's `path`;
  the audits skip those comparisons.

A scene: an optional room or floor, one to four objects (spheres, boxes, quads, inline triangle
meshes with or without normals and uvs, the uv sphere OBJ and, without --mitsuba, instances of it;
a quarter of their transforms mirror),
materials drawn from every model with random parameters (colour and roughness textures, textured
principled and dielectric scalars, texture channels and explicit srgb, alpha masks and faint
emission on any model included), and lights drawn from area quads and spheres, point, spot and
directional lights, a constant or mapped environment; a pinhole or thin-lens camera, a box or
Gaussian filter (σ up to 2 pixels), max_depth 2..8 or unbounded. Same seed, same scene. With --mitsuba only translatable content is drawn.
"""
import argparse
import json
import math
import os
import random
import shutil

HERE = os.path.dirname(os.path.abspath(__file__))
ASSETS = os.path.join(HERE, "..", "..", "scenes", "assets")
PRESETS = {  # conductor complex IOR at roughly R, G, B (Mitsuba's Au, Cu, Al)
    "gold": ([0.143, 0.374, 1.442], [3.983, 2.385, 1.603]),
    "copper": ([0.200, 0.924, 1.102], [3.912, 2.452, 2.142]),
    "aluminium": ([1.657, 0.880, 0.521], [9.224, 6.270, 4.837]),
}


class Gen:
    def __init__(self, seed, mitsuba):
        self.r = random.Random(seed)
        # The extras (alpha masks, texture channels and explicit srgb, textured scalars, emission
        # on any model, wide Gaussian filters) draw from their own stream, so a seed's base scene
        # stays what it was before they were added.
        self.x = random.Random(seed * 7919 + 1)
        # Mirrors (a transform's scale negated along one axis) draw from a third stream likewise.
        self.m = random.Random(seed * 7919 + 2)
        self.mitsuba = mitsuba
        self.features = set()
        self.materials = {}

    # --- small draws -------------------------------------------------------------------------
    def u(self, a, b):
        return round(self.r.uniform(a, b), 4)

    def chance(self, p):
        return self.r.random() < p

    def colour(self, lo=0.05, hi=0.9):
        return [self.u(lo, hi) for _ in range(3)]

    def texture(self):
        s = self.u(0.5, 4.0)
        return {"texture": "assets/checker.png", "scale": [s, s]}

    # --- materials ---------------------------------------------------------------------------
    def material(self, textured_ok=True):
        """A new random material; returns its name. Records the features it brings."""
        kinds = ["diffuse", "diffuse", "conductor", "dielectric", "principled"]
        kind = "phong" if not self.mitsuba and self.chance(0.05) else self.r.choice(kinds)
        m = {"type": kind}
        tex = textured_ok and self.chance(0.2)
        if kind == "diffuse":
            m["reflectance"] = self.texture() if tex else self.colour()
        elif kind == "conductor":
            rough = 0.0 if self.chance(0.35) else self.u(0.05, 0.6)
            if rough > 0.0:
                m["roughness"] = self.texture() if tex else rough
                if self.chance(0.3):
                    m["anisotropy"] = self.u(0.0, 0.8)
            if self.chance(0.5):
                eta, k = PRESETS[self.r.choice(sorted(PRESETS))]
                m["eta"], m["k"] = eta, k
            elif self.chance(0.5):
                m["reflectance"] = self.colour(0.3, 1.0)
        elif kind == "dielectric":
            m["ior"] = self.u(1.2, 1.9)
            if self.chance(0.5):
                m["roughness"] = self.u(0.05, 0.5)
            if self.chance(0.3):
                m["transmittance"] = self.colour(0.4, 1.0)
        elif kind == "principled":
            m["base_color"] = self.texture() if tex else self.colour()
            m["roughness"] = self.u(0.05, 0.9)
            for key, p in (("metallic", 0.5), ("spec_tint", 0.3), ("anisotropic", 0.3),
                           ("sheen", 0.3), ("sheen_tint", 0.2), ("clearcoat", 0.3),
                           ("clearcoat_gloss", 0.3), ("spec_trans", 0.2)):
                if self.chance(p):
                    m[key] = self.u(0.0, 1.0)
            if self.chance(0.3):
                m["specular"] = self.u(0.1, 1.0)
            elif self.chance(0.4):
                m["ior"] = self.u(1.2, 1.9)
        else:
            m["diffuse"] = self.colour(0.05, 0.6)
            m["specular"] = self.colour(0.0, 0.4)
            m["exponent"] = self.u(2, 200)
        if kind != "dielectric" and self.chance(0.2):
            m["two_sided"] = False
        if kind != "phong":
            self.extras(m, textured_ok)
        return self.add_material(m)

    def extra_texture(self, scalar):
        """A texture with a channel and srgb drawn from the extras stream."""
        t = {"texture": "assets/checker.png", "scale": [round(self.x.uniform(0.5, 3.0), 4)] * 2}
        if self.x.random() < 0.5:
            t["srgb"] = self.x.random() < 0.5
        if scalar or self.x.random() < 0.3:
            t["channel"] = self.x.choice(["r", "g", "b", "a", "luminance"])
        return t

    def extras(self, m, textured_ok):
        """Adds the extras to material m: textured scalars, a channel or srgb on a colour
        texture, an alpha mask, or a faint emission."""
        x = self.x
        if textured_ok and x.random() < 0.2:
            fields = {"principled": ["roughness", "metallic", "sheen", "clearcoat"],
                      "dielectric": ["roughness"] if "roughness" in m else []}.get(m["type"], [])
            if fields:
                m[x.choice(fields)] = self.extra_texture(scalar=True)
        for key in ("reflectance", "base_color"):
            if is_texture(m.get(key)) and x.random() < 0.5:
                m[key].update({k: v for k, v in self.extra_texture(False).items()
                               if k in ("srgb", "channel")})
        if textured_ok and x.random() < 0.1:
            # A binary mask (Mitsuba's `mask` blends where candela cuts at 0.5, so the reference
            # takes only masks of 0 and 1: tests/import/mitsuba/mask.png's channels are).
            m["alpha_mask"] = {"texture": "assets/mask.png",
                               "scale": [round(x.uniform(0.5, 3.0), 4)] * 2,
                               "channel": x.choice(["r", "g", "b", "a"])}
        elif x.random() < 0.05:
            m["emission"] = [round(x.uniform(0.05, 0.5), 3) for _ in range(3)]

    def add_material(self, m):
        name = f"m{len(self.materials)}"
        self.materials[name] = m
        return name

    def emitter(self, strength):
        c = self.colour(0.5, 1.0)
        return self.add_material({"type": "diffuse", "reflectance": self.colour(0.2, 0.8),
                                  "emission": [round(strength * x, 3) for x in c]})

    # --- geometry ----------------------------------------------------------------------------
    def quad(self, origin, eu, ev, material):
        self.features.add("tri_shading")  # quads carry per-face uvs and normals
        return {"type": "quad", "origin": origin, "edge_u": eu, "edge_v": ev, "material": material}

    def room(self, objects):
        floor = self.material()
        objects.append(self.quad([-3, -1, -3], [0, 0, 6], [6, 0, 0], floor))
        if self.chance(0.5):
            wall = self.material(textured_ok=False)
            objects.append(self.quad([-3, -1, -3], [6, 0, 0], [0, 5, 0], wall))
            objects.append(self.quad([-3, -1, -3], [0, 5, 0], [0, 0, 6], self.material()))
            objects.append(self.quad([3, -1, -3], [0, 0, 6], [0, 5, 0], self.material()))

    def transform(self):
        t = {"translate": [self.u(-1.5, 1.5), self.u(-0.5, 1.0), self.u(-1.5, 1.5)]}
        if self.chance(0.6):
            axis = [self.u(-1, 1), self.u(0.1, 1), self.u(-1, 1)]
            t["rotate"] = {"axis": axis, "angle": self.u(0, 360)}
        t["scale"] = self.u(0.3, 0.8) if self.chance(0.7) else [self.u(0.3, 0.8) for _ in range(3)]
        if self.m.random() < 0.25:
            s = t["scale"] if isinstance(t["scale"], list) else [t["scale"]] * 3
            k = self.m.randrange(3)
            t["scale"] = [-x if i == k else x for i, x in enumerate(s)]
        return t

    def tetrahedron(self, material):
        pos = [[0, 1, 0], [-0.9, -0.5, 0.5], [0.9, -0.5, 0.5], [0, -0.5, -1]]
        o = {"type": "triangles", "positions": pos,
             "indices": [0, 1, 2, 0, 2, 3, 0, 3, 1, 1, 3, 2], "material": material,
             "transform": self.transform()}
        # (Not on an emitter for the reference: Mitsuba takes an emitter's front side from its
        # shading normal, candela from the geometric one (docs/scene-format.md), and these
        # normals lean 63–74° off the faces; the draw is kept so later draws do not move.)
        if self.chance(0.5) and not (self.mitsuba and "emission" in self.materials[material]):
            o["normals"] = [[x / math.sqrt(sum(c * c for c in p)) for x in p] for p in pos]
        if self.chance(0.5):
            o["uvs"] = [[0.5, 1], [0, 0], [1, 0], [0.5, 0.5]]
        if "normals" in o or "uvs" in o:
            self.features.add("tri_shading")
        if "normals" in o and "uvs" not in o and self.mitsuba:
            # Mirrored with vertex normals, Mitsuba keeps the vertex order and candela reverses
            # it, so their barycentric uvs run along different edges (docs/scene-format.md's
            # transform): not a difference the audit should report.
            # (A mirror always makes the scale a list.)
            scale = o["transform"]["scale"]
            if isinstance(scale, list):
                o["transform"]["scale"] = [abs(x) for x in scale]
        return o

    def obj(self, objects, definitions):
        kind = self.r.choice(["sphere", "sphere", "box", "quad", "triangles", "mesh", "instance"])
        if kind == "instance" and self.mitsuba:
            kind = "mesh"
        mat = self.material()
        if kind == "sphere":
            self.features.add("spheres")
            r = self.u(0.3, 0.9)
            o = {"type": "sphere", "center": [self.u(-1.8, 1.8), round(-1 + r + self.u(0, 0.8), 4),
                                              self.u(-1.8, 1.8)], "radius": r, "material": mat}
        elif kind == "box":
            # 1 mm above the floor: a bottom face in the floor's plane ties with it, which each
            # renderer breaks its own way where a mask's holes show it (the audit's seed 169).
            lo = [self.u(-2, 1), -0.999, self.u(-2, 1)]
            o = {"type": "box", "min": lo,
                 "max": [lo[0] + self.u(0.3, 1), self.u(-0.5, 1), lo[2] + self.u(0.3, 1)],
                 "material": mat}
            if self.chance(0.4):
                o["transform"] = {"rotate": {"axis": [0, 1, 0], "angle": self.u(0, 90)}}
            self.features.add("tri_shading")
        elif kind == "quad":
            o = self.quad([self.u(-2, 0), -1, self.u(-2, 0)], [self.u(0.5, 2), 0, self.u(-1, 1)],
                          [self.u(-0.5, 0.5), self.u(0.5, 2), self.u(-0.5, 0.5)], mat)
        elif kind == "triangles":
            o = self.tetrahedron(mat)
        elif kind == "mesh":
            o = {"type": "mesh", "file": "assets/uv_sphere.obj", "material": mat,
                 "transform": self.transform()}
            if self.chance(0.3):
                o["smooth"] = False
            self.features.add("tri_shading")  # the OBJ has uvs (and normals)
        else:
            name = f"d{len(definitions)}"
            definitions[name] = {"type": "mesh", "file": "assets/uv_sphere.obj", "material": mat}
            self.features.update({"instances", "tri_shading"})
            for _ in range(self.r.randint(1, 3)):
                inst = {"type": "instance", "definition": name, "transform": self.transform()}
                if self.chance(0.3):
                    inst["material"] = self.material()
                objects.append(inst)
            return
        objects.append(o)

    # --- lights ------------------------------------------------------------------------------
    def lights(self, objects):
        lights, env = [], None
        if self.chance(0.5):
            s = self.u(0.4, 1.2)
            y = self.u(2.0, 3.5)
            objects.append(self.quad([-s / 2 + self.u(-1, 1), y, -s / 2 + self.u(-1, 1)],
                                     [s, 0, 0], [0, 0, s], self.emitter(self.u(4, 25))))
        if self.chance(0.15):
            self.features.add("spheres")
            objects.append({"type": "sphere", "center": [self.u(-2, 2), self.u(1, 3), self.u(-2, 2)],
                            "radius": self.u(0.1, 0.4), "material": self.emitter(self.u(5, 30))})
        if self.chance(0.25):
            lights.append({"type": "point", "position": [self.u(-2, 2), self.u(1.5, 3), self.u(-2, 2)],
                           "intensity": [round(self.u(5, 30) * c, 3) for c in self.colour(0.6, 1)]})
        if self.chance(0.2):
            spot = {"type": "spot", "position": [self.u(-2, 2), self.u(2, 3.5), self.u(-1, 3)],
                    "look_at": [self.u(-1, 1), -1, self.u(-1, 1)],
                    "intensity": [round(self.u(10, 60) * c, 3) for c in self.colour(0.6, 1)],
                    "cutoff_angle": self.u(15, 45)}
            if self.chance(0.5):
                spot["beam_width"] = round(spot["cutoff_angle"] * self.u(0.3, 0.9), 4)
            lights.append(spot)
        if self.chance(0.2):
            d = [self.u(-0.6, 0.6), -1, self.u(-0.6, 0.6)]
            lights.append({"type": "directional", "direction": d,
                           "irradiance": [round(self.u(1, 4) * c, 3) for c in self.colour(0.6, 1)]})
        if lights:
            self.features.add("delta_lights")
        if self.chance(0.45):
            self.features.add("environment")
            if self.chance(0.5):
                env = {"type": "constant", "radiance": self.colour(0.1, 1.2)}
            else:
                env = {"type": "map", "file": "assets/sky.exr", "scale": self.u(0.3, 1.5)}
                if self.chance(0.5):
                    env["rotate_y"] = self.u(0, 360)
                self.features.update({"env_map", "textures"})
        if not lights and env is None and not any(
                "emission" in self.materials[o.get("material", "")] for o in objects
                if o.get("material") in self.materials):
            objects.append(self.quad([-0.5, 3, -0.5], [1, 0, 0], [0, 0, 1], self.emitter(15)))
        return lights, env

    # --- the scene ---------------------------------------------------------------------------
    def scene(self, size):
        objects, definitions = [], {}
        if self.chance(0.8):
            self.room(objects)
        for _ in range(self.r.randint(1, 4)):
            self.obj(objects, definitions)
        lights, env = self.lights(objects)
        a = self.u(-0.7, 0.7)
        dist = self.u(4, 7)
        cam = {"position": [round(dist * math.sin(a), 4), self.u(0, 2.5), round(dist * math.cos(a), 4)],
               "look_at": [self.u(-0.3, 0.3), self.u(-0.3, 0.5), self.u(-0.3, 0.3)],
               "fov_y": self.u(35, 60)}
        if self.chance(0.2):
            cam["aperture_radius"] = self.u(0.02, 0.15)
            cam["focus_distance"] = self.u(3, 6)
        film = {"width": size, "height": size}
        if self.chance(0.3):
            film["filter"] = {"type": "gaussian", "stddev": self.u(0.3, 0.6)}
            if self.x.random() < 0.2:  # wider than a pixel's neighbourhood
                film["filter"]["stddev"] = round(self.x.uniform(0.6, 2.0), 4)
        doc = {"version": 1, "camera": cam, "film": film, "materials": self.materials,
               "objects": objects,
               "render": {"max_depth": self.r.choice([2, 3, 4, 6, 6, 8, -1])}}
        if definitions:
            doc["definitions"] = definitions
        if lights:
            doc["lights"] = lights
        if env is not None:
            doc["environment"] = env
        return doc


def is_texture(v):
    return isinstance(v, dict) and "texture" in v


def facts(gen, doc):
    """What the scene uses, from the materials its objects reach (an instance with its own
    material does not reach its definition's) and the lights and environment drawn."""
    used = []
    for o in doc["objects"]:
        if "material" in o:
            used.append(o["material"])
        elif o["type"] == "instance":
            used.append(doc["definitions"][o["definition"]]["material"])
    features = set(gen.features)
    delta_surfaces = False
    for name in used:
        m = doc["materials"][name]
        features.add(f"mat_{m['type']}")
        if any(is_texture(v) for v in m.values()):
            features.add("textures")
        if "alpha_mask" in m:
            features.add("alpha")
        smooth = not is_texture(m.get("roughness")) and m.get("roughness", 0) == 0
        delta_surfaces |= m["type"] in ("conductor", "dielectric") and smooth
    return {"features": sorted(features),
            "translatable": "mat_phong" not in features and "instances" not in features,
            "delta_lights": "lights" in doc, "delta_surfaces": delta_surfaces}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("seed", type=int)
    ap.add_argument("out")
    ap.add_argument("--size", type=int, default=32, help="film width and height")
    ap.add_argument("--mitsuba", action="store_true", help="translatable content only")
    a = ap.parse_args()
    gen = Gen(a.seed, a.mitsuba)
    doc = gen.scene(a.size)
    os.makedirs(os.path.join(a.out, "assets"), exist_ok=True)
    for f in ("checker.png", "sky.exr", "uv_sphere.obj"):
        shutil.copyfile(os.path.join(ASSETS, f), os.path.join(a.out, "assets", f))
    shutil.copyfile(os.path.join(HERE, "..", "import", "mitsuba", "mask.png"),
                    os.path.join(a.out, "assets", "mask.png"))
    with open(os.path.join(a.out, "scene.json"), "w") as f:
        json.dump(doc, f, indent=1)
    print(json.dumps({"seed": a.seed, **facts(gen, doc)}))


if __name__ == "__main__":
    main()
