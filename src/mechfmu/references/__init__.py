"""Host-side reference solutions (numpy): closed forms derived independently of the
standard-library physics that runs inside the FMUs, used to generate the shipped scenes'
reference CSVs (mechfmu references) and to check the physics and the FMUs against it."""
