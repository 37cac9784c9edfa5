"""The result of checking an answer: right or wrong, what is wrong, and a hint at why.

Every checker in ``uwtutor.exercises`` returns a ``Feedback``. In a notebook it displays itself as a short coloured
note (a check mark or a cross, the message, then the hint); in plain Python it is truthy exactly when the answer is
correct, so ``assert check_two_way_range(r)`` works in tests and in nbgrader's hidden tests.

Examples
--------
>>> from uwtutor.exercises.feedback import Feedback
>>> fb = Feedback(False, "Your answer, 3600 m, is twice the expected value.",
...               hint="A two-way travel time covers the path twice.")
>>> bool(fb)
False
>>> print(fb)
✘ Your answer, 3600 m, is twice the expected value.
  Hint: A two-way travel time covers the path twice.
"""

from __future__ import annotations

import html
import re
import textwrap
from dataclasses import dataclass, field
from typing import Any

__all__ = ["Feedback", "CORRECT_MARK", "WRONG_MARK"]

#: The mark that starts the text of a correct ``Feedback``.
CORRECT_MARK = "✔"
#: The mark that starts the text of a ``Feedback`` that is not (yet) correct.
WRONG_MARK = "✘"


_CODE_SPAN = re.compile(r"`([^`]+)`")
_STRONG = re.compile(r"(?<![\w*])\*\*(?=\S)(.+?)(?<=\S)\*\*(?![\w*])")
_EMPHASIS = re.compile(r"(?<![\w*])\*(?=[^\s*])([^*\n]+?)(?<=[^\s*])\*(?![\w*])")
_BRACED = re.compile(r"([_^])\{([^{}]+)\}")
_SINGLE_SUB = re.compile(r"(?<![\w.])([^\W\d_])_([^\W_])(?!\w)")


def _inline_html(text: str) -> str:
    """Text with light inline markup, as HTML (escaped).

    The messages of the checkers are plain text with a little markup, which is rendered here instead of shown
    literally: ``code`` (between backticks) as code, ``**strong**`` and ``*emphasis*``, and the subscripts and
    superscripts of formulas, ``x_{i+1}``, ``χ²_{Mn}``, ``e^{−ak}`` and a single-letter ``V_k``. Code spans are left
    exactly as written; line breaks become ``<br>``.

    Examples
    --------
    >>> _inline_html("the *inverse* of `P_k`, χ²_{Mn} and e^{−a} at V_k < 1")
    'the <em>inverse</em> of <code>P_k</code>, χ²<sub>Mn</sub> and e<sup>−a</sup> at V<sub>k</sub> &lt; 1'
    """
    pieces = _CODE_SPAN.split(text)  # even indices: prose; odd: the insides of code spans
    out = []
    for index, piece in enumerate(pieces):
        escaped = html.escape(piece, quote=False)
        if index % 2:
            out.append(f"<code>{escaped}</code>")
            continue
        escaped = _STRONG.sub(r"<strong>\1</strong>", escaped)
        escaped = _EMPHASIS.sub(r"<em>\1</em>", escaped)
        escaped = _BRACED.sub(lambda m: f"<{'sub' if m.group(1) == '_' else 'sup'}>{m.group(2)}"
                                        f"</{'sub' if m.group(1) == '_' else 'sup'}>", escaped)
        escaped = _SINGLE_SUB.sub(r"\1<sub>\2</sub>", escaped)
        out.append(escaped)
    return "".join(out).replace("\n", "<br>")


def _html_lines(text: str) -> str:
    """Escape ``text`` for HTML and render its inline markup (see ``_inline_html``), keeping its line breaks."""
    return _inline_html(text)


def _wrapped(text: str, width: int = 100) -> str:
    """``text`` with each line wrapped at ``width`` characters, continuation lines indented like the line."""
    out = []
    for line in text.split("\n"):
        indent = line[:len(line) - len(line.lstrip())] or ("  " if line.startswith(("✔", "✘")) else "")
        out.append(textwrap.fill(line, width=width, subsequent_indent=indent, break_long_words=False,
                                 break_on_hyphens=False) if line.strip() else line)
    return "\n".join(out)


@dataclass(frozen=True)
class Feedback:
    """The verdict on one answer, with a message that says what is wrong and a hint that says why.

    Parameters
    ----------
    correct : bool
        Whether the answer is accepted.
    message : str
        One or two sentences on what was checked and what was found, e.g. ``"Your answer, 3600 m, is twice the
        expected value."``. Never empty.
    hint : str or None
        What to look at next (the likely cause of the mistake), or ``None`` when there is nothing to add.
    details : dict
        Machine-readable facts about the check (the answer as a number, the relative error, the failing case...),
        for graders and tests. Not shown in the notebook display.

    Attributes
    ----------
    correct : bool
        Whether the answer is accepted; also the truth value of the object.
    message : str
        What was found.
    hint : str or None
        Why it may be wrong and what to try.
    details : dict
        Extra machine-readable information.

    Examples
    --------
    >>> fb = Feedback(True, "Correct: the range is 1800 m.")
    >>> fb
    ✔ Correct: the range is 1800 m.
    >>> if not fb:
    ...     print("try again")
    """

    correct: bool
    message: str
    hint: str | None = None
    details: dict[str, Any] = field(default_factory=dict, compare=False, hash=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "correct", bool(self.correct))
        if not isinstance(self.message, str) or not self.message.strip():
            raise ValueError("Feedback.message must be a non-empty string")
        if self.hint is not None and (not isinstance(self.hint, str) or not self.hint.strip()):
            raise ValueError("Feedback.hint must be a non-empty string or None")

    # -- truth value and text -------------------------------------------------------------------------------------
    def __bool__(self) -> bool:
        return self.correct

    @property
    def mark(self) -> str:
        """The check mark (correct) or the cross (not correct) that starts the text display."""
        return CORRECT_MARK if self.correct else WRONG_MARK

    def __str__(self) -> str:
        text = f"{self.mark} " + self.message.replace("\n", "\n  ")
        if self.hint:
            text += "\n  Hint: " + self.hint.replace("\n", "\n  ")
        return text

    def __repr__(self) -> str:
        return str(self)

    def _repr_pretty_(self, printer: Any, cycle: bool) -> None:  # IPython's plain-text display
        printer.text(str(self))

    def _repr_html_(self) -> str:
        colour, background = ("#1a7f37", "#e8f5ec") if self.correct else ("#b3261e", "#fcebea")
        body = f"<strong style='color:{colour}'>{self.mark}</strong> {_html_lines(self.message)}"
        if self.hint:
            body += f"<br><em>Hint:</em> {_html_lines(self.hint)}"
        return (f"<div class='uwtutor-feedback' style='border-left:4px solid {colour};background:{background};"
                f"padding:0.4em 0.8em;margin:0.2em 0'>{body}</div>")

    # -- helpers for graders --------------------------------------------------------------------------------------
    def assert_correct(self) -> Feedback:
        """Raise ``AssertionError`` with the message and hint unless the answer is correct.

        Meant for nbgrader's hidden tests and for pytest; returns the feedback itself so that it can still be
        displayed.

        Returns
        -------
        Feedback
            ``self``, when correct.

        Raises
        ------
        AssertionError
            When the answer is not correct; the error text is the feedback text, wrapped at 100 characters.
        """
        __tracebackhide__ = True  # pytest leaves this frame out of its tracebacks
        if not self.correct:
            raise AssertionError(_wrapped(str(self)))
        return self
