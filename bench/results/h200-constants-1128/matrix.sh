#!/usr/bin/env bash
# Issue 19, session of 2026-11-28 (fifth): runs `candela render` for every line
# "label|environment|binary|arguments" of $LIST (one VAR=VALUE or nothing in environment), ROUNDS times interleaved (TIME s after WARMUP s), into
# $OUT/matrix.jsonl; prints the median Msamples/s and the pass kernel's registers per label.
set -u
. bench/gpu_env.sh
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
out=$OUT/matrix.jsonl; : > $out
for round in $(seq ${ROUNDS:-2}); do
  while IFS='|' read -r label envs bin args; do
    [ -z "$label" ] && continue
    env ${envs:+"$envs"} $bin render $args -o /tmp/x.exr --time ${TIME:-0.5} --warmup ${WARMUP:-0.3} --json > /tmp/r.json 2>/tmp/r.err \
      || { echo "FAIL $label: $(tail -2 /tmp/r.err)"; continue; }
    python3 -c "import json,sys; d=json.load(open('/tmp/r.json')); print(json.dumps({'round':int(sys.argv[2]),'label':sys.argv[1],'msamples_per_s':d.get('msamples_per_s'),'kernel_s':d.get('kernel_s'),'regs':(d.get('kernel_stats') or {}).get('Register Count')}))" "$label" $round >> $out
  done < $LIST
done
python3 - $out <<'PY'
import json, sys, collections, statistics as st
r = collections.defaultdict(list); regs = {}
for l in open(sys.argv[1]):
    d = json.loads(l); r[d['label']].append(d['msamples_per_s']); regs[d['label']] = d['regs']
for k, v in r.items():
    print(k, round(st.median(v), 1), 'regs', regs[k], [round(x, 1) for x in v])
PY
