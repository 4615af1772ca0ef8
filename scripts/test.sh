#!/usr/bin/env bash
# Installs what is needed and runs the whole test suite: cargo tests, then pytest. Both build
# with the `ci` profile (Cargo.toml), so the extension and the tests share one dependency build;
# it lives in .venv-test, apart from the release build ./scripts/main.sh makes in .venv. The
# test extras include torch (about 5 GB with its CUDA wheels) for the training smoke test.
set -euo pipefail
source "$(dirname "$0")/env.sh" .venv-test test ci
echo "== installed in ${SECONDS} s; cargo fmt --check, ruff check, cargo clippy =="
cargo fmt --check
ruff check envs agents tests benchmarks
cargo clippy --quiet --profile ci --workspace --all-targets -- -D warnings
echo "== ${SECONDS} s; cargo test (rust/core) =="
cargo test --quiet --profile ci
echo "== ${SECONDS} s; cargo test (rust/ros2: the ROS 2 node, with a loopback DDS test) =="
cargo test --quiet --profile ci -p shieldnav-ros2
echo "== ${SECONDS} s; pytest =="
python -m pytest -q --durations=8 tests
echo "== done in ${SECONDS} s =="
