#!/usr/bin/env bash
# Create a separate virtual environment with other Python ANFIS packages, for
# the side-by-side timing of benchmarks/bench_anfis.py (part 4, --peers-only).
#
#   bash benchmarks/peers/make_anfis_peers.sh [VENV_DIR]   (default /tmp/anfis-peers)
#
# Everything comes from PyPI (PyTorch, which torchanfis needs, is a large
# download: PyPI's Linux wheel pulls the CUDA libraries). Every peer is
# installed on its own within PEER_INSTALL_TIMEOUT seconds (default 1200), so
# one that fails to install does not stop the others.
set -u
here="$(cd "$(dirname "$0")" && pwd)"
venv="${1:-/tmp/anfis-peers}"
python3 -m venv "$venv"
"$venv/bin/python" -m pip install --quiet --upgrade pip
"$venv/bin/python" -m pip install --quiet numpy
# PyTorch first, as TORCH_SPEC says (default: whatever torchanfis pulls in).
# A CPU build is enough: e.g. TORCH_SPEC=torch==2.13.0 where a CPU wheel of
# that version is at hand, instead of PyPI's CUDA build of several GB.
if [ -n "${TORCH_SPEC:-}" ]; then
    "$venv/bin/python" -m pip install --quiet "$TORCH_SPEC" || echo "  could not install $TORCH_SPEC"
fi
grep -v '^\s*#' "$here/requirements-anfis.txt" | grep -v '^\s*$' | while read -r req; do
    echo "installing $req"
    if ! timeout "${PEER_INSTALL_TIMEOUT:-1200}" "$venv/bin/python" -m pip install --quiet "$req"; then
        echo "  could not install $req (skipped)"
    fi
done
"$venv/bin/python" -m pip list 2>/dev/null | grep -i -E 'anfis|torch|numpy' || true
