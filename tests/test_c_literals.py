"""The C string literals the build writes into the loader's sources and flags (boundary.c_string)."""

import ast

from hypothesis import given
from hypothesis import strategies as st

from mechfmu.packaging.boundary import c_string


@given(st.text())
def test_a_c_string_literal_holds_the_texts_utf8_bytes(text):
    """Read back as a bytes literal (the same escapes as C's: \\", \\\\ and three-digit
    octal), the literal gives the text's UTF-8 bytes, whatever characters it holds."""
    literal = c_string(text)
    assert all(32 <= ord(c) < 127 for c in literal)
    assert ast.literal_eval("b" + literal) == text.encode("utf-8")


def test_a_non_ascii_character_becomes_its_utf8_bytes():
    assert c_string('é"\\') == '"\\303\\251\\"\\\\"'
