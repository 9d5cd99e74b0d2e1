#!/usr/bin/env bash
# The package as a stranger meets it, outside this checkout:
# 1. the wheel, built from the repository and installed alone into a bare venv (no extras), runs
#    `svrqp --version`, `python -m svrqp --help`, and `svrqp demo --quick` stops with one line naming
#    the extras it needs and leaves nothing behind; with those extras, the demo runs to the end;
# 2. a clone of the repository with nothing beside it (no ../shared) passes the tests that read
#    the shipped real data.
set -euo pipefail
cd "$(dirname "$0")/.."
REPO=$PWD
PY=$REPO/.venv/bin/python
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

echo "== wheel: build, install into a bare venv, run from $WORK"
"$PY" -m pip wheel --quiet --no-deps --wheel-dir "$WORK/dist" "$REPO"
WHEEL=$(ls "$WORK"/dist/svrqp-*.whl)
python3 -m venv "$WORK/bare"
"$WORK/bare/bin/python" -m pip install --quiet --upgrade pip
"$WORK/bare/bin/python" -m pip install --quiet "$WHEEL"
cd "$WORK"
export OPENBLAS_NUM_THREADS=1
"$WORK/bare/bin/svrqp" --version
"$WORK/bare/bin/python" -m svrqp --help > /dev/null
"$WORK/bare/bin/python" -c "from svrqp import datasets; assert datasets.load_fl_thermal().shape == (11115, 25)"
if "$WORK/bare/bin/svrqp" demo --quick --out "$WORK/demo-core" 2> "$WORK/core.err"; then
    echo "the demo ran without the guard extra; expected it to name the extra" >&2
    exit 1
fi
grep -q "pip install 'svrqp\[guard,ga\]'" "$WORK/core.err" || { cat "$WORK/core.err" >&2; exit 1; }
test "$(wc -l < "$WORK/core.err")" -eq 1 || { cat "$WORK/core.err" >&2; exit 1; }
test ! -e "$WORK/demo-core" || { echo "the failed demo left $WORK/demo-core behind" >&2; exit 1; }
"$WORK/bare/bin/python" -m pip install --quiet "$WHEEL[guard,ga]"
"$WORK/bare/bin/svrqp" demo --quick --out "$WORK/demo" > /dev/null
test -s "$WORK/demo/report.html" && test -s "$WORK/demo/results.json"
echo "wheel: OK"

echo "== clean clone: nothing beside the repository"
git clone --quiet "$REPO" "$WORK/alone/svrqp"
cd "$WORK/alone/svrqp"
test ! -e ../shared
PYTHONPATH="$WORK/alone/svrqp" "$PY" -m pytest -q -p no:cacheprovider tests/datasets tests/estimators/test_linear.py \
    tests/test_package_entry.py
echo "clean clone: OK"
