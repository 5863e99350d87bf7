"""The documentation site builds, with every notebook executed, and holds what a new user
looks for.

``mkdocs build`` runs as ``mkdocs.yml`` says (``strict``: any warning — a broken link, an
unresolved cross-reference, a docstring mkdocstrings cannot read — fails the build), with
the notebooks executed by mkdocs-jupyter (a cell that raises fails the build: the
notebooks' own checks against the seed papers' numbers run here, once). Then the built
pages are read: each notebook shows figures, the command line page has every verb's
``--help``, the configuration page every TOML key, and the simulators page every method
with the budgets ``sj.validity`` checks for it.
"""

from __future__ import annotations

import html
import os
import pathlib
import re
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))


def _text(page: pathlib.Path) -> str:
    """The visible text of a built page's article."""
    body = page.read_text()
    body = body[body.find("<article"):body.find("</article>")]
    return html.unescape(re.sub(r"<[^>]+>", " ", body))


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    pytest.importorskip("mkdocs")
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1", SARJAX_DOCS_EXECUTE="true",
               SARJAX_DOCS_CACHE=str(out / "cache"), PYTHONUNBUFFERED="1")
    env.pop("MPLBACKEND", None)  # the notebooks draw inline, as in Jupyter
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out / "html")],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=1500)
    log = done.stdout + done.stderr
    assert done.returncode == 0, log[-6000:]
    warnings = [line for line in log.splitlines() if line.startswith("WARNING")]
    assert not warnings, warnings
    return out / "html"


def test_notebooks_are_executed_with_figures(site):
    """Every notebook is in the site, executed: its figures are inline PNGs."""
    assert NOTEBOOKS
    for notebook in NOTEBOOKS:
        page = site / "notebooks" / notebook.stem / "index.html"
        figures = page.read_text().count("data:image/png")
        assert figures >= 1, f"{notebook.name}: no figure in the built page"


def test_reference_pages_follow_the_code(site):
    sys.path.insert(0, str(ROOT / "docs"))
    try:
        import hooks
    finally:
        sys.path.pop(0)
    from sarjax.cli.config import EXAMPLE

    cli = _text(site / "cli" / "index.html")
    for path, _ in hooks.cli_commands():
        assert f"$ {' '.join(path)} --help" in cli, path
    config = _text(site / "config" / "index.html")
    for section, key, _, _ in hooks.example_keys(EXAMPLE):
        assert key in config, (section, key)
    simulators = _text(site / "simulators" / "index.html")
    from sarjax.simulators import _registry

    for cls in _registry.SIMULATORS:
        assert cls.names[0] in simulators, cls
    for budget in ("epsilon_11", "azimuth_aliases", "azimuth_window", "chirp_edges",
                   "range_window"):
        assert budget in simulators, budget


def test_api_reference_is_rendered(site):
    """The API pages hold the docstrings (mkdocstrings ran): simulate, validity, focus."""
    api = " ".join(_text(page) for page in (site / "api").rglob("index.html"))
    for name in ("sarjax.simulate", "sarjax.validity", "sarjax.focus", "to_cphd",
                 "fit_motion"):
        assert name in api, name
