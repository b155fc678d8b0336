#!/usr/bin/env bash
# The test command: builds rqr and runs the whole suite (validation layers on, lavapipe).
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/env.sh
# Plain `cargo test`: lib, binaries, integration tests and doc tests (examples are built);
# benches are not run here (`cargo bench`).
cargo test "$@"
