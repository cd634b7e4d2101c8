#!/usr/bin/env bash
# Build the Python package (python/, PyO3 + maturin) into a virtual environment under target/
# and run its pytest suite against the CLI built from the same tree.
#
# The venv is target/python-venv (LIMITRAY_VENV overrides); the extension's Rust build goes to
# target/python (kept between runs). pip fetches maturin, numpy and pytest from PyPI. On Debian
# without python3-venv, the script installs it (as root). Extra arguments go to pytest.
#
# Exit status: pytest's, except that "no tests collected" (5) is a failure too, and a run that
# pytest could not start (interrupted, internal or usage error: 2, 3, 4) keeps its own status.
#
# Usage:
#   bash scripts/test-python.sh            # everything
#   bash scripts/test-python.sh -k eval    # some tests
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="${LIMITRAY_VENV:-$ROOT/target/python-venv}"
PY="${PYTHON:-python3}"

if ! "$PY" -c 'import venv, ensurepip' 2>/dev/null; then
    if [[ $(id -u) -ne 0 ]]; then
        echo "test-python: $PY has no venv/ensurepip; install python3-venv (needs root)" >&2
        exit 1
    fi
    echo "test-python: installing python3-venv" >&2
    export DEBIAN_FRONTEND=noninteractive
    apt-get update
    apt-get install -y --no-install-recommends python3-venv
fi

if [[ ! -x "$VENV/bin/python" ]]; then
    "$PY" -m venv "$VENV"
fi

# The CLI the tests compare against (the test profile: what `cargo test` builds).
(cd "$ROOT" && cargo build --profile test --bin limitray)
export LIMITRAY_BIN="$ROOT/target/debug/limitray"

# --force-reinstall of the package only: pip would otherwise keep an installed wheel of the
# same version although the Rust source changed.
export CARGO_TARGET_DIR="$ROOT/target/python"
"$VENV/bin/python" -m pip install --quiet --upgrade numpy pytest
"$VENV/bin/python" -m pip install --quiet --force-reinstall --no-deps "$ROOT/python"

cd "$ROOT/python"
set +e
"$VENV/bin/python" -m pytest tests "$@"
rc=$?
set -e
if [[ $rc -eq 5 ]]; then
    echo "test-python: pytest collected no tests" >&2
    exit 1
fi
exit $rc
