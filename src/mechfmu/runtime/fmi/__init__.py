"""FMU-side framework over pythonfmu (standard library only)."""
