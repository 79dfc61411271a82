"""Host side: scenes, the co-simulation master and result files."""
