"""Names from files (columns, file names, units) made safe for where mechfmu writes them.

A CSV column or a file name may hold any character: a control character (``\\x01``) makes a
JUnit file not well-formed XML, a newline splits a one-line message, a lone surrogate (a file
name's bytes that are not UTF-8) cannot be encoded at all, a ``$`` pair starts matplotlib's
math text (which raises on ``$\\frac$``). Each function here keeps the text readable and
replaces only what the target cannot hold, by its escape (``\\x01``).
"""

import re

# C0 and C1 controls, DEL, lone surrogates, the line and paragraph separators, and the two
# non-characters XML 1.0 excludes: none belongs in one line of text or in XML.
_UNPRINTABLE = re.compile("[\x00-\x1f\x7f-\x9f\u2028\u2029\ud800-\udfff\ufffe\uffff]")


def _escape(match: re.Match) -> str:
    code = ord(match.group())
    return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"


def one_line(text: str) -> str:
    """``text`` with every control character, line separator and lone surrogate replaced
    by its escape (``\\x0a``): one printable line that is also valid XML 1.0 text."""
    return _UNPRINTABLE.sub(_escape, str(text))


def plot_text(text: str) -> str:
    """``text`` for a matplotlib label or title: one_line, and ``$`` escaped (no math text)."""
    return one_line(text).replace("$", r"\$")


def joined_lines(text: str) -> str:
    """The non-blank lines of ``text``, stripped and joined with '; ', as one_line: a
    multi-line message (an FMU's log entry, a traceback) readable on one line."""
    lines = [line.strip() for line in str(text).splitlines() if line.strip()]
    return one_line("; ".join(lines))
