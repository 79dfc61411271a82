"""Write data/seed_report.md: the coursework's numbers recomputed from the numpy references."""

from pathlib import Path

from mechfmu.tools.report.seed_report import write_report

REPO_ROOT = Path(__file__).resolve().parent.parent
OUTPUT = REPO_ROOT / "data" / "seed_report.md"


def main():
    path = write_report(OUTPUT)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
