"""Launch buttons: none by default (the book is read offline), and the links a course gets when it turns them on.

``_config.yml`` keeps every launcher empty; a course that runs a JupyterHub or a Binder, or whose copy is on GitHub
(Colab), fills in its address and the repository's. This test builds a one-chapter book with the book's own
``launch_buttons`` and ``html`` settings, the course's addresses filled in, and reads the links of the built page:
each must open that chapter's notebook, in JupyterLab, from the course's repository and branch.
"""

from __future__ import annotations

import html
import json
import re
import subprocess
from urllib.parse import parse_qs, urlsplit

import pytest
import yaml

from book_paths import HTML_DIR, REPO, jupyter_book_exe

pytestmark = pytest.mark.book

COURSE = {
    "url": "https://github.com/example-course/uwtutor",
    "branch": "course-2027",
    "hub": "https://hub.example.org",
    "binder": "https://mybinder.example.org",
    "colab": "https://colab.research.google.com",
}


def _config() -> dict:
    return yaml.safe_load((REPO / "_config.yml").read_text(encoding="utf-8"))


def test_no_launch_button_by_default():
    launch = _config()["launch_buttons"]
    assert not any(launch.get(k) for k in ("binderhub_url", "jupyterhub_url", "colab_url", "thebe"))
    page = HTML_DIR / "book" / "ch01_positioning_and_errors.html"
    if page.is_file():  # the strict build's page (tests/test_book_build.py builds it)
        assert "launch-buttons" not in page.read_text(encoding="utf-8")


@pytest.fixture(scope="module")
def course_page(tmp_path_factory) -> str:
    """The HTML of a chapter built with the book's launch settings and a course's addresses."""
    root = tmp_path_factory.mktemp("course-book")
    book = _config()
    launch = dict(book["launch_buttons"], binderhub_url=COURSE["binder"], jupyterhub_url=COURSE["hub"],
                  colab_url=COURSE["colab"])
    config = {"title": "course", "only_build_toc_files": True, "execute": {"execute_notebooks": "off"},
              "html": book["html"], "launch_buttons": launch,
              "repository": {"url": COURSE["url"], "branch": COURSE["branch"], "path_to_book": ""}}
    (root / "_config.yml").write_text(yaml.safe_dump(config), encoding="utf-8")
    (root / "_toc.yml").write_text("format: jb-book\nroot: intro\nchapters:\n- file: book/chapter\n",
                                   encoding="utf-8")
    (root / "intro.md").write_text("# Course\n", encoding="utf-8")
    (root / "book").mkdir()
    nb = {"cells": [{"cell_type": "markdown", "metadata": {}, "source": ["# A chapter\n"]},
                    {"cell_type": "code", "metadata": {}, "execution_count": 1, "outputs": [], "source": ["1 + 1"]}],
          "metadata": {"kernelspec": {"name": "python3", "display_name": "Python 3", "language": "python"}},
          "nbformat": 4, "nbformat_minor": 5}
    (root / "book" / "chapter.ipynb").write_text(json.dumps(nb), encoding="utf-8")
    proc = subprocess.run([jupyter_book_exe(), "build", "--all", "-W", "-n", "--keep-going", str(root)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return (root / "_build" / "html" / "book" / "chapter.html").read_text(encoding="utf-8")


def _links(page: str) -> list[str]:
    return [html.unescape(h) for h in re.findall(r'href="([^"]+)"', page)]


def test_jupyterhub_link_pulls_the_course_repository_and_opens_the_chapter(course_page):
    hub = [u for u in _links(course_page) if u.startswith(COURSE["hub"])]
    assert len(hub) == 1, hub
    parts = urlsplit(hub[0])
    query = parse_qs(parts.query)
    assert parts.path == "/hub/user-redirect/git-pull"
    assert query["repo"] == [COURSE["url"]] and query["branch"] == [COURSE["branch"]]
    assert query["urlpath"] == ["lab/tree/uwtutor/book/chapter.ipynb"]


def test_binder_link_opens_the_chapter_in_jupyterlab(course_page):
    binder = [u for u in _links(course_page) if u.startswith(COURSE["binder"])]
    assert len(binder) == 1, binder
    parts = urlsplit(binder[0])
    assert parts.path == f"/v2/gh/example-course/uwtutor/{COURSE['branch']}"
    assert parse_qs(parts.query)["urlpath"] == ["lab/tree/book/chapter.ipynb"]


def test_colab_link_opens_the_chapter_from_github(course_page):
    colab = [u for u in _links(course_page) if u.startswith(COURSE["colab"])]
    assert colab == [f"{COURSE['colab']}/github/example-course/uwtutor/blob/{COURSE['branch']}/book/chapter.ipynb"]
