"""Write data/seed_report.md: the coursework's numbers recomputed from the numpy references
(``mechfmu report``)."""

from _venv import script_main

if __name__ == "__main__":
    script_main(__file__, "report")
