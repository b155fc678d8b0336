#!/usr/bin/env bash
# The Python package's tests: a fresh virtual environment, `pip install ./python` (built from
# source by maturin), numpy and pytest, then pytest over python/tests. Also builds the CLI
# (target/debug/rqr) the tests compare with. Arguments go to pytest.
#
# RQR_PY_PROFILE (default: dev) is the cargo profile of the extension: dev reuses what
# `cargo build` / `cargo test` compiled in target/; `release` is what a user's plain
# `pip install ./python` builds.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/ensure-setup.sh
. scripts/env.sh
venv="${RQR_PY_VENV:-target/python-venv}"
rm -rf "$venv"
python3 -m venv "$venv"
"$venv/bin/python" -m pip install --quiet --upgrade pip
"$venv/bin/python" -m pip install --quiet numpy pytest
cargo build --bin rqr
MATURIN_PEP517_ARGS="--profile ${RQR_PY_PROFILE:-dev}" \
  "$venv/bin/python" -m pip install --quiet ./python
export RQR_CLI="$PWD/target/debug/rqr"
set +e
"$venv/bin/python" -m pytest python/tests -v "$@"
status=$?
set -e
# pytest: 0 all passed, 1 failures, 2 interrupted, 3 internal error, 4 usage error, 5 no
# tests collected. Every non-zero status fails this script; 5 says why.
if [ "$status" -eq 5 ]; then
  echo "test-python.sh: pytest collected no tests" >&2
fi
exit "$status"
