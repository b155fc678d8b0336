# Sourced by scripts/rqr and scripts/test.sh: on Debian 12 runs scripts/setup-vulkan.sh (it
# installs only what is missing; once everything is there it is one dpkg-query, ~50 ms), checks
# for cargo, then sources scripts/env.sh. Elsewhere it only checks for cargo and glslc.
_rqr_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if grep -qs '^ID=debian' /etc/os-release && grep -qs 'VERSION_CODENAME=bookworm' /etc/os-release; then
  "$_rqr_root/scripts/setup-vulkan.sh" --quiet >/dev/null
elif ! command -v "${GLSLC:-glslc}" >/dev/null; then
  echo "rqr: glslc (shaderc's compiler) not found: install it (Vulkan SDK) or set GLSLC; scripts/setup-vulkan.sh automates Debian 12" >&2
  exit 1
fi
if ! command -v cargo >/dev/null; then
  echo "rqr: cargo not found: install Rust >= 1.85 with rustup (https://rustup.rs), then run this again" >&2
  exit 1
fi
. "$_rqr_root/scripts/env.sh"
unset _rqr_root
