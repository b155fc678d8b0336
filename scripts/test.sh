#!/usr/bin/env bash
# The test command: builds rqr and runs the whole suite (validation layers on, lavapipe).
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/env.sh
cargo test --all-targets "$@"
