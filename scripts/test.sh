#!/usr/bin/env bash
# Installs what is needed and runs the whole test suite: cargo tests, then pytest. Both build
# with the `ci` profile (Cargo.toml), so the extension and the tests share one dependency build.
set -euo pipefail
export MATURIN_PEP517_ARGS="--profile ci"
source "$(dirname "$0")/env.sh" test
echo "== installed in ${SECONDS} s; cargo test (rust/core) =="
cargo test --quiet --profile ci
echo "== ${SECONDS} s; pytest =="
python -m pytest -q --durations=8 tests
echo "== done in ${SECONDS} s =="
