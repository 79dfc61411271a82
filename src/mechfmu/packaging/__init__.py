"""Host side: a model into an FMU (pythonfmu's builder, the C loader, the binary patch)."""
