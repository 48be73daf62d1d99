#!/usr/bin/env bash
# Installs what candela needs on a fresh Debian machine and is missing: a Vulkan loader and driver
# (Mesa lavapipe, a CPU Vulkan driver; skipped when a Vulkan driver is already present), the
# Khronos validation layer (tests turn it on), and Mitsuba 3 (the independent reference the tests
# compare against). Safe to run again; needs root for apt-get (uses sudo when not root).
set -euo pipefail

SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi

need_apt=()
dpkg -s libvulkan1 >/dev/null 2>&1 || need_apt+=(libvulkan1)
# Any installed ICD counts as a driver; without one, install lavapipe.
if ! ls /usr/share/vulkan/icd.d/*.json /etc/vulkan/icd.d/*.json >/dev/null 2>&1; then
  need_apt+=(mesa-vulkan-drivers)
fi
dpkg -s vulkan-validationlayers >/dev/null 2>&1 || need_apt+=(vulkan-validationlayers)
if [ "${#need_apt[@]}" -gt 0 ]; then
  echo "setup: installing ${need_apt[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${need_apt[@]}" >/dev/null
fi

if [ "${CANDELA_SKIP_MITSUBA:-0}" != 1 ] && ! python3 -c "import mitsuba" >/dev/null 2>&1; then
  echo "setup: installing Mitsuba 3 (reference renderer for tests)"
  python3 -m pip install -q mitsuba==3.9.1 drjit==1.5.0
fi
echo "setup: ready"
