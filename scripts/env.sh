# Sourced by the scripts: a project virtualenv in .venv with shieldnav built (release) into it.
# Usage: source scripts/env.sh EXTRAS   (e.g. "test" or "bench")
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
if [ ! -x .venv/bin/python ]; then
  python3 -m venv .venv
fi
. .venv/bin/activate
python -m pip install -q --disable-pip-version-check "maturin>=1.7,<2"
python -m pip install -q --disable-pip-version-check -e ".[$1]"
