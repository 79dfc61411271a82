"""Host-side reports built from the numpy references (Markdown text)."""
