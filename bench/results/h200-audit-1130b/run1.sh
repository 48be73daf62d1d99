# Device call 1 wrapper (session of 2026-11-30, second): unpack the two binaries (xz, to fit the
# carry limit), time the light-vertex knock-out, then call1.sh's renders and audits.
mkdir -p .carry/n .carry/k
xz -dc .carry/n.xz > .carry/n/candela && xz -dc .carry/k.xz > .carry/k/candela && chmod +x .carry/n/candela .carry/k/candela
LIST=bench/results/h200-audit-1130b/call1.list ROUNDS=2 TIME=0.5 WARMUP=0.3 bash bench/results/h200-constants-1128/matrix.sh 2>&1 | tail -8
cp $OUT/matrix.jsonl $OUT/ko_matrix.jsonl
AUDIT_S=${AUDIT_S:-300} EXPORT_S=${EXPORT_S:-100} BIN=.carry/n/candela bash bench/results/h200-audit-1130b/call1.sh
