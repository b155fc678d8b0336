#!/usr/bin/env bash
# Installs what rqr needs to build and test on Debian 12 (bookworm): Mesa lavapipe with
# VK_KHR_acceleration_structure + VK_KHR_ray_query (Mesa >= 24.1, from bookworm-backports),
# the Vulkan loader, the validation layers and glslc (shaderc's compiler, which build.rs runs).
#
# Idempotent: safe to run many times. When everything is installed it only checks (one
# dpkg-query call, a few tens of ms), which is why scripts/rqr and scripts/test.sh run it first.
# usage: scripts/setup-vulkan.sh [--quiet]     --quiet: silent when there is nothing to do.
# Prints the variables to export at the end.
set -euo pipefail

MIN_MESA_MAJOR=24
QUIET=0
[ "${1:-}" = "--quiet" ] && QUIET=1

say() { printf '[setup-vulkan] %s\n' "$*" >&2; }

if [ ! -r /etc/os-release ] || ! grep -q '^ID=debian' /etc/os-release || ! grep -q 'VERSION_CODENAME=bookworm' /etc/os-release; then
  cat >&2 <<'MSG'
[setup-vulkan] This script automates Debian 12 (bookworm) only. Elsewhere, install:
  - a Vulkan 1.3 driver; for CPU-only machines Mesa >= 24.1 lavapipe (ray queries need it)
  - the Vulkan loader (libvulkan1 / libvulkan-dev), vulkaninfo, the Khronos validation layers
  - glslc (shaderc's compiler, also in the Vulkan SDK) on PATH, or its path in $GLSLC
MSG
  exit 1
fi

SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi

# g++: the C++ the cc crate builds (meshoptimizer for EXT_meshopt_compression; the Basis
# Universal encoder the KHR_texture_basisu tests encode with).
PKGS=(vulkan-tools vulkan-validationlayers libvulkan-dev libvulkan1 glslc spirv-tools g++)
# One dpkg-query for every package: "name installed-status version" per line.
installed() {
  dpkg-query -W -f='${Package} ${db:Status-Status} ${Version}\n' "${PKGS[@]}" mesa-vulkan-drivers 2>/dev/null || true
}
missing() {
  local state
  state=$(installed)
  local p
  for p in "${PKGS[@]}"; do
    grep -q "^$p installed " <<<"$state" || { echo "$p"; return; }
  done
  local mesa
  mesa=$(awk '$1 == "mesa-vulkan-drivers" && $2 == "installed" {print $3}' <<<"$state")
  if [ -z "$mesa" ] || ! [ "${mesa%%.*}" -ge "$MIN_MESA_MAJOR" ] 2>/dev/null; then
    echo "mesa-vulkan-drivers >= $MIN_MESA_MAJOR"
  fi
}

need=$(missing)
if [ -n "$need" ]; then
  say "missing: $need"
  if ! grep -rqs 'bookworm-backports' /etc/apt/sources.list /etc/apt/sources.list.d/; then
    say "adding bookworm-backports"
    echo 'deb http://deb.debian.org/debian bookworm-backports main' | $SUDO tee /etc/apt/sources.list.d/rqr-backports.list >/dev/null
  fi
  say "apt-get update"
  $SUDO apt-get update -qq
  say "installing mesa-vulkan-drivers from bookworm-backports and ${PKGS[*]}"
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
    -t bookworm-backports mesa-vulkan-drivers >/dev/null
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${PKGS[@]}" >/dev/null
  need=$(missing)
  [ -z "$need" ] || { say "still missing after installing: $need (mesa older than $MIN_MESA_MAJOR has no ray queries in lavapipe)"; exit 1; }
  QUIET=0
fi

LVP_ICD=/usr/share/vulkan/icd.d/lvp_icd.json
[ -f "$LVP_ICD" ] || LVP_ICD=$(ls /usr/share/vulkan/icd.d/lvp_icd*.json 2>/dev/null | head -n1)
[ "$QUIET" = 1 ] || say "ok: $(dpkg-query -W -f='mesa-vulkan-drivers ${Version}' mesa-vulkan-drivers)"
[ "$QUIET" = 1 ] || cat <<ENV
export VK_DRIVER_FILES=$LVP_ICD
ENV
