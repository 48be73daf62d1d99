#!/usr/bin/env python3
"""Seed 324 of the random-scene audit, varied one material at a time and compared as audit.py
does (block relMSE over its noise, means): variants324.py CANDELA OUT SPP NAME... (Mitsuba
variant: $VARIANT, default cuda_ad_rgb)."""
import copy, json, os, subprocess, sys
sys.path.insert(0, "tests/mitsuba")
import audit
cand, out, spp, names = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4:]
d = os.path.join(out, "s324")
subprocess.run([sys.executable, "tests/mitsuba/random_scene.py", "324", d, "--size", "64", "--mitsuba"], check=True, capture_output=True)
base = json.load(open(os.path.join(d, "scene.json")))


def run(name, v, integ):
    p = os.path.join(d, f"{name}.json")
    json.dump(v, open(p, "w"))
    mi, cs = [], []
    for s in (1, 2):
        o = os.path.join(d, f"{name}_m{s}.exr")
        subprocess.run([sys.executable, "tests/mitsuba/render_reference.py", p, o, "--spp", spp, "--seed", str(s),
                        "--variant", os.environ.get("VARIANT", "cuda_ad_rgb")], check=True, capture_output=True)
        mi.append(o)
        o = os.path.join(d, f"{name}_{integ}_c{s}.exr")
        subprocess.run([cand, "render", p, "-o", o, "--integrator", integ, "--spp", spp, "--seed", str(10 + s)],
                       check=True, capture_output=True)
        cs.append(o)
    r = audit.compare(cand, [audit.read_exr(x) for x in cs], [audit.read_exr(x) for x in mi], (cs, mi))
    print(json.dumps({"variant": name, "integrator": integ, "ratio": r["block_rel_mse"] / r["noise"],
                      "mean_candela": r["mean_candela"], "mean_mitsuba": r["mean_mitsuba"]}), flush=True)


def mat(m, **kw):
    v = copy.deepcopy(base)
    for k, x in kw.items():
        if x is None:
            v["materials"][m].pop(k, None)
        else:
            v["materials"][m][k] = x
    return v


V = {"base": base,
     "m3_diffuse": mat("m3", type="diffuse", roughness=None, anisotropy=None),
     "m1_diffuse": mat("m1", type="diffuse"),
     "m2_no_alpha": mat("m2", alpha_mask=None),
     "m3_iso": mat("m3", anisotropy=None),
     "m3_smooth": mat("m3", roughness=None, anisotropy=None),
     "m3_r015": mat("m3", roughness=0.15, anisotropy=None),
     "m0_diffuse": mat("m0", type="diffuse", ior=None, roughness=None, emission=None),
     "m0_no_emission": mat("m0", emission=None),
     "m0_smooth": mat("m0", roughness=None),
     "m0_r05": mat("m0", roughness=0.5),
     "m0_diffuse_emitter": mat("m0", type="diffuse", ior=None, roughness=None),
     "no_m8": copy.deepcopy(base)}
V["no_m8"]["objects"] = [o for o in base["objects"] if o.get("material") != "m8"]
# The floor (a diffuse emitter), the two mirrors and the left wall (no mask) alone, seen as in
# the scene (through the right wall and the back wall) or directly from inside the room.
mini = copy.deepcopy(V["m0_diffuse_emitter"])
for m in ("m2",):
    mini["materials"][m].pop("alpha_mask", None)
mini["materials"]["m3"].pop("roughness", None)
mini["materials"]["m3"].pop("anisotropy", None)
mini["objects"] = [o for o in mini["objects"] if o.get("material") in ("m0", "m1", "m2", "m3")]
V["mini"] = mini
V["mini_direct"] = copy.deepcopy(mini)
V["mini_direct"]["camera"] = {"position": [2.0, 1.0, 1.0], "look_at": [-3.0, 0.5, 0.0], "fov_y": 50.0}
V["mini_walls_diffuse"] = copy.deepcopy(V["mini_direct"])
for m in ("m1", "m3"):
    V["mini_walls_diffuse"]["materials"][m] = {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}
for k in (3, 5, 6):
    V[f"md{k}"] = copy.deepcopy(base)
    V[f"md{k}"]["render"]["max_depth"] = k
for n in names:
    integ = "nee"
    if ":" in n:
        n, integ = n.split(":")
    run(n, V[n], integ)
