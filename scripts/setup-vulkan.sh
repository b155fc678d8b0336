#!/usr/bin/env bash
# Installs what rqr needs to build and test on Debian 12 (bookworm): Mesa lavapipe with
# VK_KHR_acceleration_structure + VK_KHR_ray_query (Mesa >= 24.1, from bookworm-backports),
# the Vulkan loader, validation layers and the shaderc/glslang/SPIRV-Tools static libraries,
# merged into one archive that the `shaderc` crate links statically.
#
# Idempotent: safe to run many times. Prints the variables to export at the end
# (also written to target/vulkan-env.sh for scripts).
set -euo pipefail

SHADERC_DIR="${RQR_SHADERC_DIR:-/opt/rqr-shaderc}"
MIN_MESA_MAJOR=24

say() { printf '[setup-vulkan] %s\n' "$*" >&2; }

if [ ! -r /etc/os-release ] || ! grep -q '^ID=debian' /etc/os-release || ! grep -q 'VERSION_CODENAME=bookworm' /etc/os-release; then
  cat >&2 <<'MSG'
[setup-vulkan] This script automates Debian 12 (bookworm) only. Elsewhere, install:
  - a Vulkan 1.3 driver; for CPU-only machines Mesa >= 24.1 lavapipe (ray queries need it)
  - the Vulkan loader (libvulkan1 / libvulkan-dev), vulkaninfo, the Khronos validation layers
  - shaderc (libshaderc + glslang + SPIRV-Tools); then point SHADERC_LIB_DIR at a folder
    holding libshaderc_combined.a, or let the shaderc crate build it from source (cmake, ~13 min).
MSG
  exit 1
fi

SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi

need_install=0
mesa_ok() {
  local v
  v=$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null || true)
  [ -n "$v" ] && [ "${v%%.*}" -ge "$MIN_MESA_MAJOR" ] 2>/dev/null
}
PKGS=(vulkan-tools vulkan-validationlayers libvulkan-dev libvulkan1 libshaderc-dev glslang-dev spirv-tools glslc binutils)
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || need_install=1
done
mesa_ok || need_install=1

if [ "$need_install" = 1 ]; then
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
fi
mesa_ok || { say "mesa-vulkan-drivers is older than $MIN_MESA_MAJOR: lavapipe has no ray queries"; exit 1; }

# Debian's libshaderc.so leaves glslang symbols undefined and its libshaderc_combined.a holds
# only shaderc's own objects; merging the static archives gives one self-contained archive.
if [ ! -s "$SHADERC_DIR/libshaderc_combined.a" ]; then
  say "merging static shaderc/glslang/SPIRV-Tools archives into $SHADERC_DIR"
  libdir=/usr/lib/$(dpkg-architecture -qDEB_HOST_MULTIARCH 2>/dev/null || echo x86_64-linux-gnu)
  $SUDO mkdir -p "$SHADERC_DIR"
  tmp=$(mktemp -d)
  {
    echo "CREATE $tmp/libshaderc_combined.a"
    for a in libshaderc_combined.a libglslang.a libMachineIndependent.a libGenericCodeGen.a \
             libOSDependent.a libOGLCompiler.a libSPIRV.a libHLSL.a libSPIRV-Tools-opt.a libSPIRV-Tools.a; do
      f="$libdir/$a"
      [ -f "$f" ] || f=$(find /usr/lib -name "$a" -print -quit)
      [ -n "$f" ] && [ -f "$f" ] || { say "missing static library $a"; exit 1; }
      echo "ADDLIB $f"
    done
    echo "SAVE"
    echo "END"
  } | ar -M
  $SUDO mv "$tmp/libshaderc_combined.a" "$SHADERC_DIR/"
  rm -rf "$tmp"
fi

LVP_ICD=/usr/share/vulkan/icd.d/lvp_icd.json
[ -f "$LVP_ICD" ] || LVP_ICD=$(ls /usr/share/vulkan/icd.d/lvp_icd*.json 2>/dev/null | head -n1)
say "ok: $(dpkg-query -W -f='mesa-vulkan-drivers ${Version}' mesa-vulkan-drivers)"
cat <<ENV
export SHADERC_LIB_DIR=$SHADERC_DIR
export VK_DRIVER_FILES=$LVP_ICD
ENV
