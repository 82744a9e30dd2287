"""Generated light steel frames for tests: ``convert_small_frame(folder, (N, M))`` writes the sample with an
N×M grid of columns (``bimbot sample light-steel-frame --bays NxM``) and converts it, in process.

Each size is generated and converted once per test process (a 2×1 frame takes seconds, and a dozen test
modules ask for one); every caller gets its own copy of it, so a test may write into its build (runs/…).
"""

from __future__ import annotations

import atexit
import shutil
import tempfile
from pathlib import Path

_CONVERTED: dict[tuple[int, int], Path] = {}


def _converted_once(bays: tuple[int, int]) -> Path:
    """The folder with ``frame.ifc`` and ``build/`` of ``bays``, made on the first call; never handed out."""
    if bays not in _CONVERTED:
        from bimbot.data import light_steel_frame as sample
        from bimbot.services.converter.convert import convert_model

        folder = Path(tempfile.mkdtemp(prefix=f"bimbot-frame-{bays[0]}x{bays[1]}-"))
        atexit.register(shutil.rmtree, folder, ignore_errors=True)
        source = folder / "frame.ifc"
        model = sample.build_light_steel_frame(*bays)
        model.write(str(source))
        convert_model(model, source, folder / "build")
        _CONVERTED[bays] = folder
    return _CONVERTED[bays]


def convert_small_frame(out_dir: Path, bays: tuple[int, int] = (2, 1)) -> Path:
    """The light steel frame sample with ``bays`` columns, converted, in ``out_dir``/build (with its
    ``out_dir``/frame.ifc): a copy of this process's one conversion of that size, naming that frame.ifc."""
    converted = _converted_once(bays)
    out_dir.mkdir(parents=True, exist_ok=True)
    shutil.copy2(converted / "frame.ifc", out_dir / "frame.ifc")
    shutil.copytree(converted / "build", out_dir / "build", symlinks=True)
    manifest = out_dir / "build" / "manifest.json"  # its source: this copy's frame.ifc, as if made here
    text = manifest.read_text()
    manifest.write_text(text.replace(str(converted / "frame.ifc"), str(out_dir / "frame.ifc")))
    return out_dir / "build"
