"""Sphinx configuration of the skthermal documentation.

The site is assembled from what is in the repository when it is built, so new
pages, packages and examples appear without editing this file:

- user guide: every ``docs/*.md`` page (MyST), ordered as ``docs/index.md``
  links them, the others alphabetically after;
- API reference: one page per public module found by walking the
  ``skthermal`` package (``docs/api/<module>.rst`` are written here, the
  object pages by autosummary into ``docs/api/generated/``);
- examples gallery: every ``examples/*.py`` (sphinx-gallery), executed unless
  ``SKTHERMAL_DOCS_EXECUTE=0``.

Offline by default; ``SKTHERMAL_DOCS_INTERSPHINX=1`` links to the Python,
NumPy, SciPy, pandas, scikit-learn and matplotlib docs (fetches their
inventories).
"""

import importlib
import inspect
import os
import pkgutil
import re
import shutil
import sys
import warnings
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))

import skthermal  # noqa: E402

# -- Project -----------------------------------------------------------------

project = "skthermal"
author = "skthermal developers"
copyright = "skthermal developers"
release = skthermal.__version__
version = re.sub(r"(\.dev\d*|rc\d*|a\d*|b\d*)$", "", release)

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
]

root_doc = "index"
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
templates_path = ["_templates"]
# index.md is the body of index.rst (included there), not a page of its own.
exclude_patterns = ["_build", "index.md", "api/generated/*.examples", "**.ipynb"]
default_role = "literal"
nitpicky = False
suppress_warnings = [
    # Links of the .md pages to files outside the site (e.g. ../examples/).
    "myst.xref_missing",
]

# -- HTML --------------------------------------------------------------------

try:
    import pydata_sphinx_theme  # noqa: F401
except ImportError:  # fall back to Sphinx's built-in theme
    html_theme = "alabaster"
    html_theme_options = {}
else:
    html_theme = "pydata_sphinx_theme"
    html_theme_options = {
        "navigation_with_keys": False,
        "show_toc_level": 2,
        "header_links_before_dropdown": 6,
    }
html_title = f"skthermal {release}"
html_static_path = []
html_last_updated_fmt = None
html_copy_source = False

# -- autodoc / autosummary / numpydoc ------------------------------------------

autosummary_generate = True
autosummary_imported_members = True
autodoc_default_options = {"member-order": "bysource"}
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_attributes_as_param_list = True
numpydoc_xref_param_type = False
# Checked strictly (warnings, so errors under -W): broken sections and
# parameters that are documented but do not exist. The full numpydoc
# validation (``SKTHERMAL_DOCS_VALIDATE=all``) is advisory.
if os.environ.get("SKTHERMAL_DOCS_VALIDATE") == "all":
    numpydoc_validation_checks = {"all", "ES01", "EX01", "SA01", "RT02", "GL01"}
else:
    numpydoc_validation_checks = {"PR02", "PR10", "GL06", "GL07"}

# -- MyST ----------------------------------------------------------------------

myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

# -- intersphinx (optional: needs the network) ---------------------------------

if os.environ.get("SKTHERMAL_DOCS_INTERSPHINX") == "1":
    extensions.append("sphinx.ext.intersphinx")
    intersphinx_mapping = {
        "python": ("https://docs.python.org/3", None),
        "numpy": ("https://numpy.org/doc/stable", None),
        "scipy": ("https://docs.scipy.org/doc/scipy", None),
        "pandas": ("https://pandas.pydata.org/docs", None),
        "sklearn": ("https://scikit-learn.org/stable", None),
        "matplotlib": ("https://matplotlib.org/stable", None),
    }

# -- API reference: discover the public modules ---------------------------------

# Packages that are not part of the public API.
API_EXCLUDE = {"skthermal.utils", "skthermal.cli", "skthermal.__main__"}
API_DIR = DOCS / "api"


def _is_public(name):
    return not any(part.startswith("_") for part in name.split("."))


def public_modules():
    """Every importable public module of skthermal, package first."""
    found = ["skthermal"]
    for info in pkgutil.walk_packages(skthermal.__path__, "skthermal."):
        name = info.name
        if not _is_public(name) or any(
            name == ex or name.startswith(ex + ".") for ex in API_EXCLUDE
        ):
            continue
        found.append(name)
    return found


def public_names(module):
    """``__all__``, else the public objects defined in the module."""
    names = getattr(module, "__all__", None)
    if names is not None:
        return [n for n in names if not n.startswith("_")]
    return sorted(
        name
        for name, obj in vars(module).items()
        if not name.startswith("_")
        and (inspect.isclass(obj) or inspect.isfunction(obj))
        and getattr(obj, "__module__", "").startswith(module.__name__)
    )


def _home(obj, modules):
    """The documented module an object belongs to: its defining module's
    longest public prefix among ``modules``."""
    defining = getattr(obj, "__module__", None) or ""
    best = None
    for name in modules:
        if defining == name or defining.startswith(name + "."):
            if best is None or len(name) > len(best):
                best = name
    return best


def _title(text, char="="):
    return f"{text}\n{char * len(text)}\n"


def write_api_pages():
    """Write ``docs/api/<module>.rst``, one page per public module."""
    modules, failures = {}, []
    for name in public_modules():
        try:
            modules[name] = importlib.import_module(name)
        except Exception as exc:  # reported as a warning: an error under -W
            failures.append(f"{name}: {type(exc).__name__}: {exc}")
    if API_DIR.exists():
        for old in API_DIR.glob("*.rst"):
            old.unlink()
    API_DIR.mkdir(exist_ok=True)
    documented = [n for n in modules if n != "skthermal"]
    exports = {name: set(public_names(mod)) for name, mod in modules.items()}
    for name, module in modules.items():
        own, elsewhere, constants = [], [], []
        for attr in public_names(module):
            obj = getattr(module, attr, None)
            if attr == "__version__" or obj is None or inspect.ismodule(obj):
                continue
            # Classes and functions get one page, in the package that defines
            # them; packages re-exporting them (e.g. skthermal) link there.
            home = _home(obj, documented)
            if not (inspect.isclass(obj) or inspect.isfunction(obj)):
                constants.append((attr, obj))
            elif (
                home not in (None, name)
                and attr in exports[home]
                and getattr(modules[home], attr, None) is obj
            ):
                elsewhere.append(f"{home}.{attr}")
            else:
                own.append(attr)
        lines = [
            f".. _api-{name}:\n",
            _title(f"``{name}``"),
            f".. automodule:: {name}\n   :no-members:\n",
            f".. currentmodule:: {name}\n",
        ]
        if own:
            lines.append(
                ".. autosummary::\n   :toctree: generated/\n   :nosignatures:\n"
            )
            lines += [f"   {attr}" for attr in own]
            lines.append("")
        if constants:
            # Data: the docstring would be its type's, so show type and value.
            lines.append(".. rubric:: Constants\n")
            for attr, obj in constants:
                lines.append(f".. py:data:: {attr}\n   :type: {type(obj).__name__}")
                value = repr(obj)
                if len(value) <= 80 and "\n" not in value:
                    lines.append(f"   :value: {value}")
                lines.append("")
        if elsewhere:
            lines.append(".. rubric:: Re-exported, documented in their packages\n")
            lines.append(".. autosummary::\n   :nosignatures:\n")
            # Relative to the current module where possible (autosummary
            # warns about names that repeat it).
            lines += [
                f"   ~{full[len(name) + 1 :] if full.startswith(name + '.') else full}"
                for full in elsewhere
            ]
            lines.append("")
        page = API_DIR / f"{name}.rst"
        page.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return list(modules), failures


API_MODULES, API_FAILURES = write_api_pages()

# -- Examples gallery ----------------------------------------------------------

EXAMPLES = ROOT / "examples"
GALLERY_HEADER = DOCS / "_templates" / "gallery_header.rst"
GALLERY_SRC = DOCS / "_build" / "gallery_src"


def _has_header(folder):
    return any(folder.glob("GALLERY_HEADER.*")) or any(folder.glob("README.*"))


def _patch_gallery_header():
    """Let sphinx-gallery use docs/_templates/gallery_header.rst for examples/.

    sphinx-gallery wants a GALLERY_HEADER file beside the scripts; ours lives
    in docs/ so that examples/ holds only scripts. Returns False if this
    sphinx-gallery has no hook to patch.
    """
    try:
        from sphinx_gallery import gen_rst
    except ImportError:  # pragma: no cover - sphinx-gallery is required anyway
        return False
    original = getattr(gen_rst, "_get_gallery_header", None)
    if original is None or getattr(original, "_skthermal", False):
        return original is not None

    def _get_gallery_header(dir_, gallery_conf, raise_error=True):
        found = original(dir_, gallery_conf, raise_error=False)
        if found is None and Path(dir_).resolve() == EXAMPLES.resolve():
            if not (Path(dir_) / "index.rst").is_file():
                return str(GALLERY_HEADER)
        if found is None and raise_error:
            return original(dir_, gallery_conf, raise_error=True)
        return found

    _get_gallery_header._skthermal = True
    gen_rst._get_gallery_header = _get_gallery_header
    return True


def gallery_source():
    """The folder sphinx-gallery reads: examples/ itself where possible.

    Fallback for a sphinx-gallery without the patched hook: a folder of
    symbolic links to the scripts plus the header. The examples then run with
    that folder as working directory.
    """
    if _has_header(EXAMPLES) or _patch_gallery_header():
        return EXAMPLES
    if GALLERY_SRC.exists():
        shutil.rmtree(GALLERY_SRC)
    GALLERY_SRC.mkdir(parents=True)
    shutil.copy2(GALLERY_HEADER, GALLERY_SRC / "GALLERY_HEADER.rst")
    for script in sorted(EXAMPLES.glob("*.py")):
        target = GALLERY_SRC / script.name
        try:
            target.symlink_to(script.resolve())
        except OSError:
            shutil.copy2(script, target)
    return GALLERY_SRC


EXECUTE = os.environ.get("SKTHERMAL_DOCS_EXECUTE", "1") != "0"

sphinx_gallery_conf = {
    "examples_dirs": os.path.relpath(gallery_source(), DOCS),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "ignore_pattern": r"__init__\.py",
    "plot_gallery": EXECUTE,
    "download_all_examples": False,
    "doc_module": ("skthermal",),
    "backreferences_dir": "api/generated",
    "reference_url": {"skthermal": None},
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "within_subsection_order": "FileNameSortKey",
    "show_memory": False,
    # No sg_execution_times.rst in docs/ (times are printed in the log).
    "write_computation_times": False,
    "show_signature": False,
    "image_scrapers": ("matplotlib",),
    "abort_on_example_error": False,
    "only_warn_on_example_error": False,
}

warnings.filterwarnings(
    "ignore",
    category=UserWarning,
    message="Matplotlib is currently using agg, which is a non-GUI backend",
)

# -- User guide ------------------------------------------------------------------

USER_GUIDE_MARK = "..  user-guide-pages (filled in by conf.py)"


def user_guide_pages(found_docs):
    """The ``docs/*.md`` pages Sphinx found, in the order ``index.md`` links
    them, the others alphabetically after."""
    pages = sorted(
        doc
        for doc in found_docs
        if "/" not in doc and doc != "index" and (DOCS / f"{doc}.md").is_file()
    )
    index = DOCS / "index.md"
    linked = []
    if index.exists():
        for stem in re.findall(r"\]\(\s*([\w-]+)\.md", index.read_text("utf-8")):
            if stem in pages and stem not in linked:
                linked.append(stem)
    return linked + [p for p in pages if p not in linked]


def _fill_placeholders(app, docname, source):
    if docname == "index" and USER_GUIDE_MARK in source[0]:
        pages = user_guide_pages(app.env.found_docs)
        entries = "\n".join(f"   {page}" for page in pages)
        source[0] = source[0].replace(USER_GUIDE_MARK, entries)
    if docname == "api":
        entries = "\n".join(f"   api/{name}" for name in API_MODULES)
        source[0] = source[0].replace("..  api-pages (filled in by conf.py)", entries)


def _skip_sklearn_members(app, what, name, obj, skip, options):
    """Leave out members inherited from scikit-learn (documented there, with
    cross-references into scikit-learn's own site)."""
    if skip or what != "class":
        return None
    defining = getattr(obj, "__module__", None) or ""
    qualname = getattr(obj, "__qualname__", "") or ""
    if defining.startswith("sklearn.") or "RequestMethod" in qualname:
        return True
    return None


# Plain-text names ending in an underscore (``n_features_in_`` in a type) and
# bars (``|z - p|``) are reST references and substitutions; in docstrings they
# mean neither. Escape them outside inline markup, doctests and literal blocks.
_INLINE = re.compile(r"(``.+?``|(?::[\w.:+-]+:)?`[^`]+`_{0,2}|\*\*.+?\*\*|\$[^$]+\$)")
_TRAILING = re.compile(r"(?<![\w\\])([A-Za-z]\w*[A-Za-z0-9])_(?![\w`])")
_BAR = re.compile(r"(?<![\\|])\|(?!\|)")


def _escape_plain(text):
    parts = _INLINE.split(text)
    for i in range(0, len(parts), 2):
        part = _TRAILING.sub(r"\1\\_", parts[i])
        stripped = part.lstrip()
        indent = part[: len(part) - len(stripped)]
        if i == 0 and stripped.startswith("| "):  # a line block
            parts[i] = indent + "| " + _BAR.sub(r"\\|", stripped[2:])
        else:
            parts[i] = _BAR.sub(r"\\|", part)
    return "".join(parts)


def _escape_docstring(app, what, name, obj, options, lines):
    literal_indent = None
    in_doctest = False
    pending_literal, pending_indent = False, 0
    for k, line in enumerate(lines):
        stripped = line.strip()
        indent = len(line) - len(line.lstrip())
        if not stripped:
            in_doctest = False
            continue
        if literal_indent is not None:
            if indent > literal_indent:
                continue
            literal_indent = None
        if pending_literal:
            pending_literal = False
            if indent > pending_indent:
                literal_indent = pending_indent
                continue
        if stripped.startswith(">>>") or in_doctest:
            in_doctest = True
            continue
        if stripped.startswith(".. "):
            # Directives: their bodies (e.g. math, code) are left alone.
            literal_indent = indent
            continue
        lines[k] = _escape_plain(line)
        if stripped.endswith("::"):
            pending_literal, pending_indent = True, indent


def _report_import_failures(app):
    from sphinx.util import logging

    logger = logging.getLogger("skthermal.docs")
    for failure in API_FAILURES:
        logger.warning("API reference: cannot import %s", failure)


def setup(app):
    app.connect("source-read", _fill_placeholders)
    app.connect("autodoc-skip-member", _skip_sklearn_members)
    # After numpydoc (priority 500) has turned the sections into reST.
    app.connect("autodoc-process-docstring", _escape_docstring, priority=900)
    app.connect("builder-inited", _report_import_failures)
