#!/usr/bin/env bash
# Builds the release artefacts into dist/ and checks them:
#   - one wheel for every CPython >= 3.10 (the stable ABI, abi3) on manylinux_2_28 x86_64, built
#     with maturin and zig (so the wheel needs glibc 2.28, whatever the build host has), and
#     auditwheel-checked by maturin; generic x86-64 code, the SIMD level chosen at run time;
#   - the sdist;
#   - `twine check --strict` on both;
#   - the ROS 2 node's release binary, built with --locked and the source path remapped (the
#     same sources and toolchain give the same binary), its size and the glibc it needs;
#   - tests/test_wheel.py: the wheel installed into a fresh virtual environment with no cargo
#     or rustc on PATH, the README's quick starts and `shieldnav info` run from it.
# Tools (maturin, ziglang, twine, pytest) live in .venv-release, apart from the other venvs.
# Usage: ./scripts/wheel.sh [--no-test]
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
TOOLS=.venv-release
if [ ! -x "$TOOLS/bin/python" ]; then
  python3 -m venv "$TOOLS"
fi
# (activated: maturin finds zig as `python -m ziglang` of the interpreter on PATH)
. "$TOOLS/bin/activate"
python -m pip install -q --disable-pip-version-check "maturin>=1.7,<2" "ziglang>=0.13,<0.14" twine pytest
rm -rf dist
mkdir -p dist
echo "== wheel (abi3, manylinux_2_28, x86_64) =="
maturin build --release --features abi3 --compatibility manylinux_2_28 --zig --out dist
echo "== sdist =="
maturin sdist --out dist
twine check --strict dist/*
echo "== the ROS 2 node =="
RUSTFLAGS="${RUSTFLAGS:-} --remap-path-prefix=$ROOT=shieldnav --remap-path-prefix=$HOME/.cargo=cargo" \
  cargo build --release --locked -p shieldnav-ros2 --target-dir target/node
cp target/node/release/shieldnav-ros2 dist/
glibc=$(objdump -T dist/shieldnav-ros2 | grep -o 'GLIBC_[0-9.]*' | sort -uV | tail -1)
for f in dist/*; do
  printf '%-70s %8.1f MB\n' "$(basename "$f")" "$(echo "$(stat -c %s "$f") / 1048576" | bc -l)"
done
echo "shieldnav-ros2 needs $glibc or newer; sha256 $(sha256sum dist/shieldnav-ros2 | cut -c1-16)"
if [ "${1:-}" != "--no-test" ]; then
  echo "== the wheel in a fresh environment, without a Rust toolchain =="
  SHIELDNAV_WHEEL="$(ls dist/*.whl)" python -m pytest -q -s -p no:cacheprovider --noconftest tests/test_wheel.py
fi
