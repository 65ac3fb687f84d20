"""The Python examples of README.md and docs/*.md run as written.

Each page's kept ```python blocks run in page order in one fresh namespace
(a later block uses the names of an earlier one), in a temporary working
directory. A failure names the page and the line of the block.

Not kept, and why:

- blocks that read a file made on the command line (each says how in a
  comment): README.md (``my_machine_tests.csv``); command_line.md (a
  ``model.skops`` written by ``skthermal fit``); deployment.md
  (``machine_b_tests.csv``, and the blocks that use the ``model`` or
  ``model.skops`` of it); dynamic_compensation.md, gap.md and
  simulation.md's calibration (``tests.csv``); gap_external.md
  (``sim.csv``, ``real.csv``); own_machine.md (``my_rig_tests.csv``);
  run_tables.md (``tests.csv.gz``, ``tests.parquet``); sensor_selection.md
  (``machine_b_tests.csv``);
- illustrative blocks, with names the page leaves to the reader:
  deployment.md (``run_so_far``, ``alarm``, ``RollingMean``);
  own_machine.md's check of ``initial="auto"`` (``sampled``, ``train`` and
  ``params`` of examples/plot_own_machine.py);
  model_selection.md (``search.py`` reads ``sys.argv[1]``; a PostgreSQL
  server); sensor_selection.md (``regressor``);
- slow blocks: model_selection.md's two searches (50 and 20 Optuna trials,
  about 12 s and 18 s on one core; only their imports run here, for the
  blocks after them), update_regression.md's selector on 20 batches and
  the cross-batch RMSE after it (11 s and 3 s).

``test_every_python_block_compiles`` checks the syntax of every block,
illustrative ones included.
"""

import ast
import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PAGES = ["README.md", *sorted(f"docs/{p.name}" for p in (REPO / "docs").glob("*.md"))]

# Per page, the blocks to execute, in page order: (marker, how). The marker is
# a string found in exactly one ```python block of the page; how is "run" (the
# whole block) or "imports" (only its import statements: a block that cannot
# run here, whose imports a later block uses).
EXAMPLES = {
    "docs/deployment.md": [
        ('warnings.simplefilter("error", SkthermalVersionWarning)', "run"),
    ],
    "docs/dynamic_compensation.md": [
        ('load_fl_thermal("../shared/data")', "run"),
    ],
    "docs/model_selection.md": [
        ("n_trials=50,", "imports"),
        ('search_space("anfis", init="fcm", n_clusters=(2, 5)', "run"),
        ("def my_space(trial):", "run"),
    ],
    "docs/other_systems.md": [
        ("VirtualSensorExtractor(grid=(15, 35)", "run"),
        ("correct_fbg_strain(raw_ue, temperature_C)", "run"),
        ("model.fit_modules(", "run"),
    ],
    "docs/own_machine.md": [
        ('.spec.to_toml("my_rig.toml")', "run"),
        ('ThermalMachine.from_spec("my_rig.toml", effects=[])', "run"),
    ],
    "docs/replication.md": [
        ('reproduce("report", seed=1', "run"),
    ],
    "docs/run_tables.md": [
        ("concat_runs([heating, cooling])", "run"),
    ],
    "docs/simulation.md": [
        ("DoorEvent(start_h=1.5)", "run"),
        ('ThermalMachine.from_spec("my-rig.toml", effects=[])', "run"),
        ("T = machine.response(time_s, spindle_rpm, ambient_C)  #", "run"),
        ("first = run_table.iloc[:5]", "run"),
    ],
    "docs/update_regression.md": [
        ("runs = make_batch_campaign(n_batches=20, random_state=0)", "run"),
    ],
}

# ```toml blocks that a kept block reads from a file: (marker, file name).
TOML_FILES = {
    "docs/simulation.md": [('name = "my-rig"', "my-rig.toml")],
}

# The pages refer to the reference data relative to the repository root.
SHARED_DATA_IN_DOCS = "../shared/data"

_FENCE = re.compile(r"^(\s*)(`{3,})(\S*)\s*$")


def _blocks(page):
    """The fenced blocks of a page: (language, line of the opening fence, code)."""
    lines = (REPO / page).read_text(encoding="utf-8").splitlines()
    found = []
    i = 0
    while i < len(lines):
        match = _FENCE.match(lines[i])
        if not match:
            i += 1
            continue
        indent, fence, lang = match.groups()
        end = i + 1
        while end < len(lines) and lines[end].strip() != fence:
            end += 1
        code = "\n".join(line.removeprefix(indent) for line in lines[i + 1 : end])
        found.append((lang, i + 1, code))
        i = end + 1
    return found


def _the_block(blocks, lang, marker, page):
    hits = [
        (line, code) for kind, line, code in blocks if kind == lang and marker in code
    ]
    assert len(hits) == 1, (
        f"{page}: {len(hits)} ```{lang} blocks contain {marker!r}, expected 1; "
        "update EXAMPLES or TOML_FILES in tests/test_docs_examples.py"
    )
    return hits[0]


@pytest.mark.parametrize("page", sorted(EXAMPLES))
def test_doc_examples_run(page, tmp_path, monkeypatch, request):
    if page == "docs/model_selection.md":
        pytest.importorskip("optuna")
    blocks = _blocks(page)
    chosen = sorted(
        (*_the_block(blocks, "python", marker, page), how)
        for marker, how in EXAMPLES[page]
    )
    if any(SHARED_DATA_IN_DOCS in code for _, code, _ in chosen):
        shared_data = request.getfixturevalue("shared_data").as_posix()
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    for marker, name in TOML_FILES.get(page, []):
        _, toml = _the_block(blocks, "toml", marker, page)
        (tmp_path / name).write_text(toml + "\n", encoding="utf-8")

    namespace = {"__name__": "__docs__"}
    for line, code, how in chosen:
        if SHARED_DATA_IN_DOCS in code:
            code = code.replace(SHARED_DATA_IN_DOCS, shared_data)
        # Blank lines in front, so that a traceback gives the page's line numbers.
        tree = ast.parse("\n" * line + code)
        if how == "imports":
            tree.body = [
                n for n in tree.body if isinstance(n, ast.Import | ast.ImportFrom)
            ]
        try:
            exec(compile(tree, str(REPO / page), "exec"), namespace)
        except Exception as exc:
            raise AssertionError(
                f"{page}:{line}: the example raised {type(exc).__name__}: {exc}"
            ) from exc


@pytest.mark.parametrize("page", PAGES)
def test_every_python_block_compiles(page):
    for lang, line, code in _blocks(page):
        if lang != "python":
            continue
        try:
            compile("\n" * line + code, str(REPO / page), "exec")
        except SyntaxError as exc:
            raise AssertionError(f"{page}:{line}: {exc}") from exc
