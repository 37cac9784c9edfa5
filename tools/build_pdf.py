"""Build the PDF edition of the book (`make pdf`): the same sources as the HTML, through Jupyter Book's LaTeX builder.

The PDF's configuration is _config.yml with _config_pdf.yml merged over it (mappings key by key, anything else
replaced), and its table of contents is _toc.yml without the pages _config_pdf.yml lists under ``pdf_exclude``. Both
are written to _build/pdf/, and the book is built from them into _build/pdf/_build/latex/ (its own doctrees: an HTML
build may run at the same time in _build/). The PDF is copied to _build/pdf/uwtutor.pdf.

    python tools/build_pdf.py            # the whole build (what `make pdf` runs)
    python tools/build_pdf.py --config   # only write the merged configuration and table of contents

The build is strict like the HTML one (``-W -n --keep-going``, every page re-read); LaTeX's own log is checked by
tests/test_pdf.py.
"""

from __future__ import annotations

import argparse
import copy
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parents[1]
PDF_DIR = REPO / "_build" / "pdf"
LATEX_DIR = PDF_DIR / "_build" / "latex"
PDF_NAME = "uwtutor"
PDF = PDF_DIR / f"{PDF_NAME}.pdf"
LOG = PDF_DIR / "pdf-build.log"


def merge(base, overlay):
    """``overlay`` over ``base``: mappings merged key by key, any other value replaced."""
    if isinstance(base, dict) and isinstance(overlay, dict):
        out = copy.deepcopy(base)
        for key, value in overlay.items():
            out[key] = merge(base[key], value) if key in base else copy.deepcopy(value)
        return out
    return copy.deepcopy(overlay)


def _without(node, excluded: set[str]):
    """A copy of a _toc.yml node without the entries whose ``file`` (suffix or not) is in ``excluded``."""
    if isinstance(node, list):
        return [_without(item, excluded) for item in node
                if not (isinstance(item, dict) and _stem(item.get("file", "")) in excluded)]
    if isinstance(node, dict):
        return {key: _without(value, excluded) for key, value in node.items()}
    return node


def _stem(file: str) -> str:
    return re.sub(r"\.(md|ipynb|rst)$", "", str(file))


def pdf_config() -> tuple[dict, dict]:
    """The PDF's _config.yml and _toc.yml, as mappings."""
    config = yaml.safe_load((REPO / "_config.yml").read_text(encoding="utf-8"))
    overlay = yaml.safe_load((REPO / "_config_pdf.yml").read_text(encoding="utf-8"))
    excluded = set(overlay.pop("pdf_exclude", []) or [])
    toc = yaml.safe_load((REPO / "_toc.yml").read_text(encoding="utf-8"))
    config = merge(config, overlay)
    # Jupyter Book finds local extensions relative to the configuration file, which is written to PDF_DIR.
    local = config.get("sphinx", {}).get("local_extensions") or {}
    for name, path in local.items():
        local[name] = os.path.relpath(REPO / path, PDF_DIR)
    return config, _without(toc, excluded)


def write_config() -> tuple[Path, Path]:
    config, toc = pdf_config()
    PDF_DIR.mkdir(parents=True, exist_ok=True)
    header = "# Written by tools/build_pdf.py from {} : do not edit.\n"
    config_path, toc_path = PDF_DIR / "_config.yml", PDF_DIR / "_toc.yml"
    config_path.write_text(header.format("_config.yml and _config_pdf.yml")
                           + yaml.safe_dump(config, sort_keys=False, allow_unicode=True), encoding="utf-8")
    toc_path.write_text(header.format("_toc.yml and _config_pdf.yml's pdf_exclude")
                        + yaml.safe_dump(toc, sort_keys=False, allow_unicode=True), encoding="utf-8")
    return config_path, toc_path


def build_cmd(config_path: Path, toc_path: Path) -> list[str]:
    jb = Path(sys.executable).with_name("jupyter-book")
    return [str(jb) if jb.exists() else "jupyter-book", "build", "--all", "-W", "-n", "--keep-going",
            "--builder", "pdflatex", "--config", str(config_path), "--toc", str(toc_path),
            "--path-output", str(PDF_DIR), "."]


def build() -> int:
    """Build the PDF; the output of Sphinx and LaTeX goes to the terminal and to _build/pdf/pdf-build.log."""
    config_path, toc_path = write_config()
    PDF.unlink(missing_ok=True)
    # LaTeX's files of an earlier run would let latexmk skip passes; Sphinx rewrites the .tex anyway.
    shutil.rmtree(LATEX_DIR, ignore_errors=True)
    with LOG.open("w", encoding="utf-8") as log:
        proc = subprocess.Popen(build_cmd(config_path, toc_path), cwd=REPO, stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True, errors="replace")
        assert proc.stdout is not None
        for line in proc.stdout:
            sys.stdout.write(line)
            log.write(line)
        code = proc.wait()
    built = LATEX_DIR / f"{PDF_NAME}.pdf"
    if code == 0 and built.is_file():
        shutil.copy2(built, PDF)
        print(f"\nThe PDF is built: {PDF}")
        return 0
    print(f"\nThe PDF build failed (exit code {code}); log: {LOG}", file=sys.stderr)
    return code or 1


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", action="store_true", help="only write the merged configuration and toc")
    args = parser.parse_args(argv)
    if args.config:
        for path in write_config():
            print(path)
        return 0
    return build()


if __name__ == "__main__":
    sys.exit(main())
