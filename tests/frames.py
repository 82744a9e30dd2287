"""Generated light steel frames for tests: ``convert_small_frame(folder, (N, M))`` writes the sample with an
N×M grid of columns (``bimbot sample light-steel-frame --bays NxM``) and converts it, in process."""

from __future__ import annotations

from pathlib import Path


def convert_small_frame(out_dir: Path, bays: tuple[int, int] = (2, 1)) -> Path:
    """Generate the light steel frame sample with ``bays`` columns and convert it into ``out_dir``/build."""
    from bimbot.services.converter import sample_light_steel_frame as sample
    from bimbot.services.converter.convert import convert_model

    out_dir.mkdir(parents=True, exist_ok=True)
    source = out_dir / "frame.ifc"
    model = sample.build_light_steel_frame(*bays)
    model.write(str(source))
    convert_model(model, source, out_dir / "build")
    return out_dir / "build"
