"""uwtutor: single-beacon underwater acoustic navigation, the library behind the uwtutor textbook."""

__version__ = "0.1.0"
