#!/usr/bin/env bash
# The test command: sets the machine up when something is missing (scripts/ensure-setup.sh),
# then builds rqr and runs the whole suite (validation layers on, lavapipe).
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/ensure-setup.sh
# Plain `cargo test`: lib, binaries, integration tests and doc tests (examples are built);
# benches are not run here (`cargo bench`).
cargo test "$@"
