#!/usr/bin/env bash
# Issue 12 on the NVIDIA GPU machine (../shared/gpu/README.md): every integrator (INTEGRATORS,
# default all six) on every project scene with each --accel of ACCELS (default "bvh cwbvh") and
# each binary of BINS (default $BIN, else .carry/main/candela; a second one, e.g.
# .carry/base/candela, gives a before/after in the same call), 1280x720, the scene's max_depth,
# TIME seconds (default 1) after a WARMUP (default 0.5) s warm-up. Usage: bash
# bench/gpu_accel_scenes.sh OUT.jsonl. Writes one JSON line per run to OUT.jsonl; prints a
# markdown table: Msamples/s, cwbvh / bvh of the first binary and, with two binaries, first /
# second per accel.
set -u
cd "$(dirname "$0")/.."
. bench/gpu_env.sh
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
out=$1; bins=${BINS:-${BIN:-.carry/main/candela}}
: > "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for s in scenes/*.json; do
  for i in ${INTEGRATORS:-pt nee bdpt whitted deferred vct}; do
    for a in ${ACCELS:-bvh cwbvh}; do
      for bin in $bins; do
        "$bin" render "$s" -o $tmp/x.exr --integrator $i --accel $a --width 1280 --height 720 \
          --time ${TIME:-1} --warmup ${WARMUP:-0.5} --json > $tmp/r.json 2>$tmp/r.err \
          || { echo "FAIL $bin $s $i $a: $(tail -2 $tmp/r.err)"; continue; }
        python3 -c "import json,sys; d=json.load(open(sys.argv[5])); print(json.dumps({'bin':sys.argv[4],'scene':sys.argv[1],'integrator':sys.argv[2],'accel':sys.argv[3],'msamples_per_s':d.get('msamples_per_s'),'compile_s':d.get('compile_s')}))" "$s" $i $a "$bin" "$tmp/r.json" >> "$out"
      done
    done
  done
done
python3 - "$out" $bins <<'PY'
import json, sys, collections
bins = sys.argv[2:]
r = collections.defaultdict(dict)
for l in open(sys.argv[1]):
    d = json.loads(l); r[(d['scene'][7:-5], d['integrator'])][(d['bin'], d['accel'])] = d['msamples_per_s']
cols = [(b, a) for b in bins for a in ('bvh', 'cwbvh')]
head = ['scene', 'integrator'] + [f'{a} {b}' for b, a in cols] + ['cwbvh / bvh']
if len(bins) > 1:
    head += [f'{a}: first / second' for a in ('bvh', 'cwbvh')]
print('| ' + ' | '.join(head) + ' |')
print('|' + '---|' * len(head))
for k, v in r.items():
    cells = [f"{v[c]:.1f}" if c in v else '' for c in cols]
    b0 = bins[0]
    ratio = f"{v[(b0, 'cwbvh')] / v[(b0, 'bvh')]:.3f}" if (b0, 'cwbvh') in v and (b0, 'bvh') in v else ''
    ab = []
    if len(bins) > 1:
        for a in ('bvh', 'cwbvh'):
            p, q = (bins[0], a), (bins[1], a)
            ab.append(f"{v[p] / v[q]:.3f}" if p in v and q in v else '')
    print('| ' + ' | '.join([k[0], k[1]] + cells + [ratio] + ab) + ' |')
PY
