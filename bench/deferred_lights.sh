#!/usr/bin/env bash
# Times `deferred` against the number of lights on one scene (bench/make_many_lights.py: a
# 60×60 floor with pillars and spheres, N lights of constant total intensity, so the expected
# number of lights per pixel stays the same for every N; see docs/deferred.md).
#
# usage: bench/deferred_lights.sh [--candela PATH] [--width 1920] [--height 1080] [--spp 16]
#                                 [--lights "1 10 100 1000 10000"] [--options JSON]
#                                 [--device NAME] [--out DIR]
#
# For every N it writes DIR/scene_N.json, renders it once untimed (1 spp: kernel build and
# device warm-up) and then with `candela render --integrator deferred --json`, and collects
# from the JSON report: wall and GPU time of the passes, the per-sample GPU time of each stage
# (G-buffer, cull, shade, from the dispatch timestamps), the lights after the light manager,
# the mean and largest tile-list length and overflowed tiles (of the last sample), the lights
# tested and shaded per pixel (mean over all samples), and the memory of the stage buffers. Results: DIR/results.csv, DIR/results.md (a table) and the raw
# reports DIR/render_N.json. --options passes integrator options through, e.g.
# '{"shadows": true}' or '{"cutoff": 0.01, "max_lights_per_pixel": 16}'. No network is used.
set -euo pipefail

here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/.." && pwd)"
candela="$root/target/release/candela"
width=1920
height=1080
spp=16
lights="1 10 100 1000 10000"
options='{}'
device=""
out="$root/bench-out/deferred_lights"

while [ $# -gt 0 ]; do
  case "$1" in
    --candela) candela="$2"; shift 2 ;;
    --width) width="$2"; shift 2 ;;
    --height) height="$2"; shift 2 ;;
    --spp) spp="$2"; shift 2 ;;
    --lights) lights="$2"; shift 2 ;;
    --options) options="$2"; shift 2 ;;
    --device) device="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    -h|--help) sed -n '2,20p' "$0"; exit 0 ;;
    *) echo "unknown argument: $1 (see --help)" >&2; exit 2 ;;
  esac
done

if [ ! -x "$candela" ]; then
  echo "no candela binary at $candela (cargo build --release -p candela-server, or --candela PATH)" >&2
  exit 2
fi
mkdir -p "$out"
dev_args=()
if [ -n "$device" ]; then dev_args=(--device "$device"); fi

for n in $lights; do
  scene="$out/scene_$n.json"
  python3 "$here/make_many_lights.py" "$n" "$scene" --width "$width" --height "$height" --spp "$spp"
  echo "== $n lights: warm-up" >&2
  "$candela" render "$scene" -o "$out/warmup.exr" --integrator deferred --options "$options" \
    --spp 1 --width "$width" --height "$height" "${dev_args[@]}" --json > /dev/null
  echo "== $n lights: $spp spp at ${width}x${height}" >&2
  "$candela" render "$scene" -o "$out/render_$n.exr" --integrator deferred --options "$options" \
    --spp "$spp" --width "$width" --height "$height" "${dev_args[@]}" --json > "$out/render_$n.json"
done
rm -f "$out/warmup.exr"

python3 - "$out" "$root" "$options" $lights <<'PY'
import csv, json, subprocess, sys
out, root, options, ns = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4:]
try:
    import os
    commit = os.environ.get("CANDELA_COMMIT") or subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True, cwd=root).stdout.strip() or "unknown"
except OSError:
    commit = "unknown"
cols = ["lights", "lights_after_manager", "width", "height", "spp", "time_s", "gpu_time_s",
        "ms_per_sample", "gbuffer_ms", "cull_ms", "shade_ms", "mean_tile_lights",
        "max_tile_lights", "tested_per_pixel", "shaded_per_pixel", "overflowed_tiles", "stage_memory_mib", "gbuffer_bytes_per_pixel",
        "rays_per_s", "device", "driver", "commit", "options"]
rows = []
for n in ns:
    r = json.load(open(f"{out}/render_{n}.json"))
    d = r.get("details") or {}
    per = d.get("stage_ms_per_sample", {})
    tl = d.get("tile_lists", {})
    lpp = d.get("lights_per_pixel", {})
    mem = d.get("memory_bytes", {})
    spp = r["spp"]
    rows.append({
        "lights": int(n),
        "lights_after_manager": d.get("lights", {}).get("culled", 0) + d.get("lights", {}).get("directional", 0),
        "width": r["width"], "height": r["height"], "spp": spp,
        "time_s": round(r["time_s"], 4), "gpu_time_s": round(r["gpu_time_s"], 4),
        "ms_per_sample": round(1e3 * r["gpu_time_s"] / max(spp, 1), 3),
        "gbuffer_ms": round(per.get("gbuffer", 0.0), 3), "cull_ms": round(per.get("cull", 0.0), 3),
        "shade_ms": round(per.get("shade", 0.0), 3),
        "mean_tile_lights": round(tl.get("mean_lights", 0.0), 1),
        "max_tile_lights": tl.get("max_lights", 0),
        "tested_per_pixel": round(lpp.get("tested", 0.0), 1),
        "shaded_per_pixel": round(lpp.get("shaded", 0.0), 1), "overflowed_tiles": tl.get("overflowed_tiles", 0),
        "stage_memory_mib": round(mem.get("total", 0) / 2**20, 2),
        "gbuffer_bytes_per_pixel": d.get("gbuffer_bytes_per_pixel", 0),
        "rays_per_s": round(r.get("rays_per_s", 0.0)),
        "device": r["device"]["name"], "driver": r["device"].get("driver", ""),
        "commit": commit, "options": options,
    })
with open(f"{out}/results.csv", "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=cols)
    w.writeheader()
    w.writerows(rows)
show = ["lights", "lights_after_manager", "ms_per_sample", "gbuffer_ms", "cull_ms", "shade_ms",
        "mean_tile_lights", "max_tile_lights", "tested_per_pixel", "shaded_per_pixel",
        "overflowed_tiles", "stage_memory_mib"]
with open(f"{out}/results.md", "w") as f:
    r0 = rows[0]
    f.write(f"# deferred: GPU time against the number of lights\n\n"
            f"{r0['width']}x{r0['height']}, {r0['spp']} spp, options `{options}`, "
            f"device {r0['device']} ({r0['driver']}), commit {commit}. Times are GPU times per "
            f"sample from the dispatch timestamps (ms); tile lists are those of the last sample.\n\n")
    f.write("| " + " | ".join(show) + " |\n|" + "---|" * len(show) + "\n")
    for r in rows:
        f.write("| " + " | ".join(str(r[c]) for c in show) + " |\n")
print(open(f"{out}/results.md").read())
PY
