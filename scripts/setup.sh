#!/usr/bin/env bash
# Installs what candela needs on a fresh Debian machine and is missing: a Vulkan loader and driver
# (Mesa lavapipe, a CPU Vulkan driver; skipped when a Vulkan driver is already present), the
# Khronos validation layer (tests turn it on), Chromium and the npm packages of the browser test
# (skip with CANDELA_SKIP_BROWSER=1), and Mitsuba 3 (the independent reference the tests compare
# against; skip with CANDELA_SKIP_MITSUBA=1), and PostgreSQL (the store tests run on it too; skip with
# CANDELA_SKIP_POSTGRES=1). Safe to run again; needs root for apt-get (uses sudo when not root).
set -euo pipefail

SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi

need_apt=()
dpkg -s libvulkan1 >/dev/null 2>&1 || need_apt+=(libvulkan1)
# Any installed ICD counts as a driver; without one, install lavapipe.
if ! compgen -G "/usr/share/vulkan/icd.d/*.json" >/dev/null && ! compgen -G "/etc/vulkan/icd.d/*.json" >/dev/null; then
  need_apt+=(mesa-vulkan-drivers)
fi
dpkg -s vulkan-validationlayers >/dev/null 2>&1 || need_apt+=(vulkan-validationlayers)
# Browser test: Debian's Chromium (driven by playwright-core; no browser is ever downloaded) and Node.js.
if [ "${CANDELA_SKIP_BROWSER:-0}" != 1 ]; then
  dpkg -s chromium >/dev/null 2>&1 || need_apt+=(chromium)
  command -v node >/dev/null 2>&1 || need_apt+=(nodejs npm)
fi
# PostgreSQL server binaries (Debian: /usr/lib/postgresql/N/bin; the tests look there).
if [ "${CANDELA_SKIP_POSTGRES:-0}" != 1 ] && ! command -v initdb >/dev/null 2>&1 \
  && ! compgen -G "/usr/lib/postgresql/*/bin/initdb" >/dev/null; then
  need_apt+=(postgresql)
fi
if [ "${#need_apt[@]}" -gt 0 ]; then
  echo "setup: installing ${need_apt[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${need_apt[@]}" >/dev/null
fi

if [ "${CANDELA_SKIP_BROWSER:-0}" != 1 ]; then
  if [ "$(node -p 'process.versions.node.split(".")[0]' 2>/dev/null || echo 0)" -lt 20 ]; then
    echo "setup: the browser test needs Node.js 20 or newer (found $(node --version 2>/dev/null || echo none))" >&2
    exit 1
  fi
  if [ ! -d "$(dirname "$0")/../tests/browser/node_modules/playwright-core" ]; then
    echo "setup: installing the browser test's npm packages"
    PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1 npm ci --prefix "$(dirname "$0")/../tests/browser" --no-audit --no-fund --loglevel=error
  fi
fi

if [ "${CANDELA_SKIP_MITSUBA:-0}" != 1 ] && ! python3 -c "import mitsuba" >/dev/null 2>&1; then
  echo "setup: installing Mitsuba 3 (reference renderer for tests)"
  python3 -m pip install -q mitsuba==3.9.1 drjit==1.5.0
fi
echo "setup: ready"
