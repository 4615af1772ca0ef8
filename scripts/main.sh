#!/usr/bin/env bash
# Installs what is needed and runs the main job: the shield benchmark (whole filter call from
# Python, composite vs the distance baseline, planar and 3D), then the Rust latency table.
set -euo pipefail
source "$(dirname "$0")/env.sh" bench
python benchmarks/bench_shield.py "$@"
cargo bench --quiet -p shieldnav-core --bench shield_latency
