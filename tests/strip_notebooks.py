"""Strip outputs, execution counts and editor metadata from notebooks: `make strip`."""

import json
import sys
from pathlib import Path

KEEP_CELL_METADATA = {"tags"}


def strip(path: Path) -> bool:
    nb = json.loads(path.read_text())
    before = json.dumps(nb, sort_keys=True)
    for cell in nb["cells"]:
        cell["metadata"] = {k: v for k, v in cell.get("metadata", {}).items()
                            if k in KEEP_CELL_METADATA}
        if cell["cell_type"] == "code":
            cell["outputs"], cell["execution_count"] = [], None
    nb["metadata"] = {k: v for k, v in nb["metadata"].items()
                      if k in ("kernelspec", "language_info")}
    changed = json.dumps(nb, sort_keys=True) != before
    if changed:
        path.write_text(json.dumps(nb, indent=1, ensure_ascii=False) + "\n")
    return changed


if __name__ == "__main__":
    for name in sys.argv[1:]:
        if strip(Path(name)):
            print("stripped", name)
