"""The benchmarks' result files: one JSON object per line (benchmarks/results/*.jsonl)."""
from __future__ import annotations

import json
from pathlib import Path

__all__ = ["read_rows"]


def read_rows(path: str | Path) -> list[dict]:
    """The rows of the JSON-lines file ``path``, blank lines skipped; [] when it does not exist
    (a run that has written nothing yet)."""
    path = Path(path)
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
