#!/usr/bin/env bash
# Installs what is needed and runs the main job: the benchmark of the scripted inspection stack
# (the paper's planner and P controller) under every shield and without one, on the paper's
# three scenarios, procedural sites and a real building map. Arguments go to the harness
# (python -m agents.benchmark --help). Results land in results/benchmark/. The release build
# lives in .venv; ./scripts/test.sh builds its own in .venv-test.
set -euo pipefail
source "$(dirname "$0")/env.sh" .venv bench release
echo "== installed in ${SECONDS} s; python -m agents.benchmark $* =="
python -m agents.benchmark "$@"
