# Sourced by the scripts: a virtualenv with shieldnav built into it, the build's progress shown.
# Usage: source scripts/env.sh VENV EXTRAS PROFILE
#   VENV     .venv (main job: a release wheel, installed) or .venv-test (tests: an editable
#            `ci`-profile build); separate, so neither script replaces the other's build
#   EXTRAS   the optional dependencies (bench, test, ...)
#   PROFILE  release: a wheel in the venv; ci: an editable install (the extension built into
#            envs/shieldnav, which the test venv alone imports)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
VENV="$1"
if [ ! -x "$VENV/bin/python" ]; then
  echo "== creating $VENV (first run: Python packages and the Rust build take several minutes) =="
  python3 -m venv "$VENV"
fi
. "$VENV/bin/activate"
python -m pip install -q --disable-pip-version-check "maturin>=1.7,<2"
LOG="$VENV/install.log"
echo "== installing shieldnav[$2] into $VENV ($3 build); progress below, full log in $LOG =="
if [ "$3" = release ]; then
  TARGET=(".[$2]")
else
  export MATURIN_PEP517_ARGS="--profile $3"
  TARGET=(-e ".[$2]")
fi
# pip -v streams cargo's output: show what is being fetched and compiled, keep the rest in the log
if ! python -m pip install -v --disable-pip-version-check "${TARGET[@]}" 2>&1 | tee "$LOG" \
    | { grep --line-buffered -E '^(Collecting|Successfully installed)|^ *(Compiling|Finished) |^(error|ERROR)' || true; }; then
  tail -n 40 "$LOG"
  echo "== installing shieldnav[$2] failed: full log in $LOG ==" >&2
  exit 1
fi
