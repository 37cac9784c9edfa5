"""The book's sources (not a library package): this file only gives ``book/conftest.py`` a module name of its own
(``book.conftest``), so that pytest does not confuse it with ``tests/conftest.py``."""
