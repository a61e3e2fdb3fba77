"""MkDocs hooks of the documentation site (mkdocs.yml): pages made from files outside ``docs/``.

- ``index.md`` is the README, its links into ``docs/`` made relative to the site;
- ``changelog.md`` is CHANGELOG.md;
- ``licences.md`` is the LICENSE and the list of data made elsewhere (``maps/NOTICES.md``);
- ``notebooks/*.ipynb`` are the repository's notebooks, which mkdocs-jupyter executes and renders.

Nothing is copied into ``docs/``: the pages are made while the site is built.
"""

from __future__ import annotations

import re
from pathlib import Path

from mkdocs.config.defaults import MkDocsConfig
from mkdocs.plugins import event_priority
from mkdocs.structure.files import File, Files

REPO = Path(__file__).resolve().parents[1]
NOTEBOOKS = "notebooks"

# a Markdown link or image target that starts with docs/ (the README's view of the documentation)
_DOCS_LINK = re.compile(r"\]\(docs/")
ROOT_FILES = {"LICENSE": "licences.md", "maps/NOTICES.md": "licences.md", "CHANGELOG.md": "changelog.md"}
"""Files of the repository the README links to -> the site's pages made from them."""


def readme_page() -> str:
    """The README as the site's home page: links into docs/ become links within the site, and
    links to the licence, the data notices and the changelog go to their pages."""
    text = _DOCS_LINK.sub("](", (REPO / "README.md").read_text(encoding="utf-8"))
    for file, page in ROOT_FILES.items():
        text = text.replace(f"]({file})", f"]({page})")
    return text


def licences_page() -> str:
    """The project's licence and the notices of the data it ships, as one page."""
    licence = (REPO / "LICENSE").read_text(encoding="utf-8")
    notices = (REPO / "maps" / "NOTICES.md").read_text(encoding="utf-8")
    notices = re.sub(r"^# ", "## ", notices, flags=re.MULTILINE)
    return ("# Licences\n\nnxtnav is free software under the MIT licence (the repository's `LICENSE`):\n\n"
            f"```text\n{licence.strip()}\n```\n\n"
            "The data it ships lies in `maps/` of the repository (the package `toolkit.data` once installed); "
            "the paths below are relative to that folder.\n\n" + notices)


@event_priority(100)  # before mkdocs-jupyter turns the notebooks into pages
def on_files(files: Files, config: MkDocsConfig) -> Files:
    """Add the pages made from the README, the changelog, the licences, and the notebooks."""
    generated = {
        "index.md": readme_page(),
        "changelog.md": (REPO / "CHANGELOG.md").read_text(encoding="utf-8"),
        "licences.md": licences_page(),
    }
    for path, content in generated.items():
        files.append(File.generated(config, path, content=content))
    for nb in sorted((REPO / NOTEBOOKS).glob("*.ipynb")):
        files.append(File(f"{NOTEBOOKS}/{nb.name}", src_dir=str(REPO), dest_dir=config.site_dir,
                          use_directory_urls=config.use_directory_urls))
    return files
