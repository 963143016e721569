"""What the thin tools/eval_*.py scripts share: put the repository on sys.path and run
`pyvehtrack.eval.<module>.main`, its data folder defaulting to ../shared/data/<folder>
beside the repository."""
import importlib
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def run(module: str, data_folder: str | None = None) -> None:
    sys.path.insert(0, str(ROOT))
    main = importlib.import_module(f"pyvehtrack.eval.{module}").main
    if data_folder is None:
        sys.exit(main())
    sys.exit(main(default_data=ROOT.parent / "shared" / "data" / data_folder))
