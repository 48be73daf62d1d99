# Device call 5 (session of 2026-11-30, second): more fresh random scenes against Mitsuba 3 (from
# seed 679) and exporter audits (from 665), build n = f46f52b.
mkdir -p .carry/n && xz -dc .carry/n.xz > .carry/n/candela && chmod +x .carry/n/candela
AUDIT_S=${AUDIT_S:-330} EXPORT_S=${EXPORT_S:-110} SEEDS=679:760 XSEEDS=665:760 BIN=.carry/n/candela \
  bash bench/results/h200-audit-1130b/call1.sh
