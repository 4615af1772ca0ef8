#!/usr/bin/env bash
# Installs what is needed and runs the whole test suite: cargo tests, then pytest.
set -euo pipefail
source "$(dirname "$0")/env.sh" test
echo "== cargo test (rust/core) =="
cargo test --quiet
echo "== pytest =="
python -m pytest -q tests
