#!/usr/bin/env bash
# Installs what is needed and runs the whole test suite: cargo tests, then pytest. Both build
# with the `ci` profile (Cargo.toml), so the extension and the tests share one dependency build.
set -euo pipefail
export MATURIN_PEP517_ARGS="--profile ci"
source "$(dirname "$0")/env.sh" test
echo "== cargo test (rust/core) =="
cargo test --quiet --profile ci
echo "== pytest =="
python -m pytest -q tests
