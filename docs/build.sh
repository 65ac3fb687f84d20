#!/usr/bin/env bash
# Build the documentation site into docs/_build/html; non-zero exit on failure.
#
# Warnings are errors (-W), reported all at once (--keep-going). Environment:
#   PYTHON=...                      interpreter with skthermal[docs] (default: python)
#   SKTHERMAL_DOCS_EXECUTE=0        do not run the examples (gallery without output;
#                                   running them needs the reference data in
#                                   ../shared/data next to the repository)
#   SKTHERMAL_DOCS_INTERSPHINX=1    link to Python/NumPy/sklearn... docs (network)
#   SKTHERMAL_DOCS_VALIDATE=all     full numpydoc validation (a to-do list: fails -W)
#   SPHINXOPTS="..."                extra sphinx-build options (e.g. -j auto)
# Extra arguments are passed to sphinx-build.
set -euo pipefail

DOCS="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
PYTHON="${PYTHON:-python}"
export MPLBACKEND=Agg

# A clean build every time: stale generated pages would hide removed modules
# or examples, and incremental builds leave old navigation in unchanged pages.
rm -rf "$DOCS/api" "$DOCS/auto_examples" "$DOCS/_build" \
    "$DOCS/sg_execution_times.rst"

# shellcheck disable=SC2086
"$PYTHON" -m sphinx -b html -W --keep-going -q ${SPHINXOPTS:-} \
    -d "$DOCS/_build/doctrees" "$DOCS" "$DOCS/_build/html" "$@"
echo "docs built: $DOCS/_build/html/index.html"
