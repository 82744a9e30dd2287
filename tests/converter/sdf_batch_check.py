"""Check SDF files with libsdformat's ``cmdCheck``, the function ``ign sdf -k`` calls, in one process.

Usage: ``python sdf_batch_check.py LIBRARY RESULTS.json FILE...``; writes the return codes (0: valid) as a
JSON list in the order of the files. The parser's own messages go to this process's stdout and stderr.
"""

from __future__ import annotations

import ctypes
import json
import sys
from pathlib import Path


def main(library: str, results: str, paths: list[str]) -> None:
    sdformat = ctypes.CDLL(library)
    sdformat.cmdCheck.argtypes = [ctypes.c_char_p]
    sdformat.cmdCheck.restype = ctypes.c_int
    codes = [sdformat.cmdCheck(str(Path(path).resolve()).encode()) for path in paths]
    Path(results).write_text(json.dumps(codes))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3:])
