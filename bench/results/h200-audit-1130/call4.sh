# Device call 4 (session of 2026-11-30): JSON -> Mitsuba XML -> JSON round trips on random scenes,
# candela nee renders of the original and of the round-tripped scene compared (roundtrip.py).
BIN=${BIN:-.carry/h/candela}
. bench/gpu_env.sh >/dev/null 2>&1
mkdir -p /tmp/mi && tar xJf .carry/mitsuba-cp312.tar.xz -C /tmp/mi && export PYTHONPATH=/tmp/mi
timeout ${AUDIT_S:-280} python3 bench/results/h200-audit-1130/roundtrip.py --candela $BIN --seeds ${SEEDS:-558:700} --out /tmp/rt > $OUT/roundtrip.txt 2>&1
cp /tmp/rt/roundtrip.jsonl $OUT/; tail -2 $OUT/roundtrip.txt | cut -c1-400
