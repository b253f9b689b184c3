#!/usr/bin/env bash
# Installs the system packages manylights needs when they are missing (Debian/Ubuntu):
#  - a software GPU adapter (Mesa lavapipe: mesa-vulkan-drivers + libvulkan1) when no Vulkan driver exists;
#  - libllvm19 for Mitsuba's llvm_ad_rgb variant (used by reference renders; scalar_rgb works without it);
#  - libembree-dev (Embree 3) for the CPU backend's shadow-ray packets (the build works without it, slower).
# As root it installs them; otherwise it prints the command to run.
set -euo pipefail
# Optional: Embree 3 (libembree-dev); without it the build traces shadow rays its own way, one at a time.
if [ ! -e /usr/include/embree3/rtcore.h ] && command -v apt-get >/dev/null 2>&1; then
  if [ "$(id -u)" -eq 0 ]; then
    echo "setup: installing libembree-dev (Embree 3: the CPU backend's shadow-ray packets)"
    (export DEBIAN_FRONTEND=noninteractive; apt-get update -qq && \
      apt-get install -y -qq --no-install-recommends libembree-dev >/dev/null) || \
      echo "setup: libembree-dev could not be installed: building without Embree (slower CPU shadow rays)" >&2
  else
    echo "setup: optional, for 2-3x faster CPU shadow rays: sudo apt-get install -y libembree-dev" >&2
  fi
fi
need=()
if ! ls /usr/share/vulkan/icd.d/*.json /etc/vulkan/icd.d/*.json >/dev/null 2>&1; then
  need+=(mesa-vulkan-drivers libvulkan1)
elif ! ldconfig -p 2>/dev/null | grep -q 'libvulkan.so.1'; then
  need+=(libvulkan1)
fi
if ! ldconfig -p 2>/dev/null | grep -q 'libLLVM.so.19\|libLLVM-19.so'; then
  need+=(libllvm19)
fi
if [ ${#need[@]} -eq 0 ]; then
  echo "setup: system packages present (Vulkan ICD, libvulkan, libLLVM 19)"
  exit 0
fi
if ! command -v apt-get >/dev/null 2>&1; then
  echo "setup: missing system packages: ${need[*]} (no apt-get here: install their equivalents)" >&2
  exit 0
fi
if [ "$(id -u)" -ne 0 ]; then
  echo "setup: not root; please run: sudo apt-get install -y --no-install-recommends ${need[*]}" >&2
  exit 0
fi
echo "setup: installing ${need[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${need[@]}" >/dev/null
echo "setup: installed ${need[*]}"
