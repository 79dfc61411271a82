"""Mechanism physics: pure functions, standard library only (they run inside the FMUs)."""
