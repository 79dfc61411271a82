"""Host-side tools behind the ``mechfmu`` verbs: sweeps, the accuracy study, benchmarks,
fuzzing, SSP export, reports, other FMI hosts, and the shipped scenes' references."""
