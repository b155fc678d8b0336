#!/usr/bin/env bash
# Validates glTF / GLB files with the Khronos glTF-Validator; exits non-zero on any error.
#   scripts/validate-gltf.sh assets/default_scene.glb [more files...]
# Needs node and npm; installs the pinned `gltf-validator` npm package into .tools/ (ignored
# by git) on first use.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
version="2.0.0-dev.3.10"
prefix="$root/.tools/gltf-validator"
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  echo "validate-gltf: node and npm are required (Debian: apt-get install nodejs npm)" >&2
  exit 2
fi
if [ ! -f "$prefix/node_modules/gltf-validator/package.json" ] ||
   ! grep -q "\"version\": \"$version\"" "$prefix/node_modules/gltf-validator/package.json"; then
  mkdir -p "$prefix"
  npm install --silent --no-audit --no-fund --prefix "$prefix" "gltf-validator@$version" >&2
fi
export GLTF_VALIDATOR_PATH="$prefix/node_modules/gltf-validator"
exec node "$root/scripts/validate-gltf.mjs" "$@"
