#!/usr/bin/env bash
# Packs this machine's PostgreSQL 15 server (the binaries bench/farm_scaling.py runs: postgres,
# initdb, pg_ctl, pg_isready; its lib and share folders; the shared libraries they need beyond
# glibc, into /opt/pglibs) as .carry/pg15.tar.xz, for the NVIDIA GPU machine, which has no
# PostgreSQL and no network (bench/gpu_farm.sh unpacks it into /). Needs scripts/setup.sh's
# postgresql here.
set -eu
cd "$(dirname "$0")/.."
b=$(mktemp -d)
chmod 755 "$b"  # the archive's "." becomes / on unpacking: keep it world-readable
bin=/usr/lib/postgresql/15/bin
mkdir -p "$b/opt/pglibs" "$b$bin" "$b/usr/lib/postgresql/15/lib" "$b/usr/share/postgresql"
tools="postgres initdb pg_ctl pg_isready"
for t in $tools; do cp "$bin/$t" "$b$bin/"; done
(cd /usr/lib/postgresql/15/lib && ls | grep -v -e llvmjit -e bitcode | xargs -I{} cp -r {} "$b/usr/lib/postgresql/15/lib/")
cp -r /usr/share/postgresql/15 "$b/usr/share/postgresql/"
for t in $tools; do ldd "$bin/$t"; done | awk '{print $3}' | grep '^/' | sort -u \
  | grep -v -E 'libc\.so|libm\.so|libpthread|libdl\.so|ld-linux|librt\.so' | xargs -I{} cp -L {} "$b/opt/pglibs/"
mkdir -p .carry
tar cJf .carry/pg15.tar.xz -C "$b" .
rm -rf "$b"
ls -la .carry/pg15.tar.xz
