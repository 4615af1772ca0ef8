#!/usr/bin/env bash
# The long fuzzing run: the property-based tests of tests/test_fuzz.py (hypothesis: the Shield,
# gym.make keywords and actions, mutated map files) and of rust/core/tests/fuzz_props.rs
# (proptest: the map YAML parser and loader, the shield's filter functions) with large case
# counts, at least 10^6 cases in all by default. The two suites run side by side, one process
# each (the machine's two cores); the case count each test ran is summed and printed at the end.
#
# Usage: ./scripts/fuzz.sh            (installs into .venv-test as ./scripts/test.sh does)
#        FUZZ_NO_INSTALL=1 ./scripts/fuzz.sh   (the active Python, shieldnav importable)
# Environment:
#   FUZZ_PY_EXAMPLES   hypothesis examples per Python test (default 1000; the map-file tests
#                      and MapInspection's keywords, a map load each, run a tenth of them)
#   FUZZ_RUST_CASES    PROPTEST_CASES per Rust test (default 200000; the map-image test runs a
#                      twentieth, the PGM-header test a quarter)
#
# Failing inputs are kept as regression cases, replayed by the normal test command:
#   - Python: the shrunk failing example is written to tests/regressions/<test>-<hash>.repr (the
#     repr of its arguments; tests/test_fuzz.py::test_regressions replays each file), and
#     hypothesis's example database in .hypothesis/ replays it first in the next long run;
#   - Rust: proptest saves the failing case's seed to rust/core/tests/regressions/fuzz_props.txt,
#     replayed first by every later run of the tests.
# Commit the new files of both folders along with the fix (or, for a fix that lies elsewhere,
# with an `XFAIL` entry in tests/test_fuzz.py naming its cause).
set -uo pipefail
if [ -z "${FUZZ_NO_INSTALL:-}" ]; then
  source "$(dirname "$0")/env.sh" .venv-test test ci
fi
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
PY_EXAMPLES="${FUZZ_PY_EXAMPLES:-1000}"
RUST_CASES="${FUZZ_RUST_CASES:-200000}"
LOGS="$(mktemp -d)"
start=$SECONDS

echo "== building the Rust property tests =="
cargo test --quiet --profile ci -p shieldnav-core --test fuzz_props --no-run || exit 1

echo "== fuzzing: hypothesis ($PY_EXAMPLES examples per test) and proptest ($RUST_CASES cases per test); logs in $LOGS =="
SHIELDNAV_FUZZ=long SHIELDNAV_FUZZ_EXAMPLES="$PY_EXAMPLES" SHIELDNAV_FUZZ_COUNT_FILE="$LOGS/py.count" \
  python -m pytest -q -p no:randomly tests/test_fuzz.py >"$LOGS/python.log" 2>&1 &
py_pid=$!
PROPTEST_CASES="$RUST_CASES" SHIELDNAV_FUZZ_COUNT_FILE="$LOGS/rust.count" \
  cargo test --quiet --profile ci -p shieldnav-core --test fuzz_props -- --test-threads=1 >"$LOGS/rust.log" 2>&1 &
rust_pid=$!
wait "$py_pid"; py_rc=$?
wait "$rust_pid"; rust_rc=$?

sum() { [ -f "$1" ] && awk '{ s += $1 } END { print s + 0 }' "$1" || echo 0; }
py_cases=$(sum "$LOGS/py.count")
rust_cases=$(sum "$LOGS/rust.count")
echo "== python: exit $py_rc, $py_cases cases =="
tail -n 15 "$LOGS/python.log"
echo "== rust: exit $rust_rc, $rust_cases cases =="
tail -n 15 "$LOGS/rust.log"
git status --short tests/regressions rust/core/tests/regressions 2>/dev/null | sed 's/^/new or changed regression case: /'
echo "== fuzzed $((py_cases + rust_cases)) cases (python $py_cases, rust $rust_cases) in $((SECONDS - start)) s =="
[ "$py_rc" -eq 0 ] && [ "$rust_rc" -eq 0 ]
