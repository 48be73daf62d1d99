#!/usr/bin/env python3
"""Round trip through Mitsuba XML on random scenes (session of 2026-11-30).

    python3 roundtrip.py --candela BIN --seeds A:B --out DIR [--size 64] [--spp 4096]

For each seed: random_scene.py --mitsuba, `candela convert scene.json x.xml` (the exporter),
`candela convert x.xml back.json` (the importer), and candela `nee` renders of scene.json (seeds
11, 12) and of back.json (seeds 13, 14) compared with audit.py's criteria (back.json in the
candela role, scene.json in the reference role). docs/import.md says the round trip keeps the
scene except film settings, the look-at distance and environment texels (resampled); the
exporter's binary masks become nearest-filtered textures (square hole corners). One JSON line
per seed; a seed the exporter refuses is skipped with its reason.
"""
import argparse
import json
import os
import subprocess
import sys

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
sys.path.insert(0, os.path.join(REPO, "tests", "mitsuba"))
from audit import compare, read_exr, run  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--candela", required=True)
    ap.add_argument("--seeds", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--spp", type=int, default=4096)
    a = ap.parse_args()
    first, end = (int(x) for x in a.seeds.split(":"))
    os.makedirs(a.out, exist_ok=True)
    log = open(os.path.join(a.out, "roundtrip.jsonl"), "w")
    for seed in range(first, end):
        d = os.path.join(a.out, f"s{seed}")
        facts = json.loads(run([sys.executable, os.path.join(REPO, "tests/mitsuba/random_scene.py"),
                                str(seed), d, "--size", str(a.size), "--mitsuba"]))
        rec = {"seed": seed, "features": facts["features"]}
        scene, xml, back = (os.path.join(d, n) for n in ("scene.json", "x.xml", "back.json"))
        r = subprocess.run([a.candela, "convert", scene, xml], capture_output=True, text=True)
        try:
            if r.returncode != 0 and "cannot express this exactly" in r.stderr:
                rec["skipped"] = r.stderr.strip()[-300:]
            else:
                if r.returncode != 0:
                    raise RuntimeError(f"export: {r.stderr.strip()[-500:]}")
                run([a.candela, "convert", xml, back])
                imgs = {}
                for name, path, seeds in (("orig", scene, (11, 12)), ("back", back, (13, 14))):
                    for s in seeds:
                        p = os.path.join(d, f"{name}{s}.exr")
                        run([a.candela, "render", path, "-o", p, "--integrator", "nee", "--spp",
                             str(a.spp), "--seed", str(s)])
                        imgs[p] = read_exr(p)
                names = list(imgs)
                rec.update(compare(a.candela, [imgs[names[2]], imgs[names[3]]],
                                   [imgs[names[0]], imgs[names[1]]],
                                   ((names[2], names[3]), (names[0], names[1]))))
        except RuntimeError as e:
            rec["fails"] = [str(e)]
        print(json.dumps(rec), flush=True)
        log.write(json.dumps(rec) + "\n")
        log.flush()


if __name__ == "__main__":
    main()
