"""What the converter leaves out once every element is converted: context massing and small fittings.

Both rules need the elements' converted boxes and masses (:mod:`.context_massing`, :mod:`.small_fittings`),
so they run after the shards: the elements they name lose their components and model folders, and each
gets a skipped entry with its reason, as an element left out at selection does.
"""

from __future__ import annotations

import logging
import shutil
from pathlib import Path

import ifcopenshell

from bimbot.shared.manifest import SkippedElement

from .component_writer import skipped_entry
from .context_massing import context_reasons
from .shards import ShardResult, without_elements
from .small_fittings import small_fitting_reasons

_log = logging.getLogger(__name__)


def without_left_out(
    elements: list[ifcopenshell.entity_instance],
    results: list[ShardResult],
    out_dir: Path,
    *,
    build_context: bool = False,
) -> tuple[list[ShardResult], list[SkippedElement]]:
    """``results`` without the context massing (unless ``build_context``) and the small fittings, their
    model folders removed, and a skipped entry for each of their elements."""
    components = [component for result in results for component in result.components]
    reasons = small_fitting_reasons(components)
    if not build_context:
        reasons.update(context_reasons(components))
    if not reasons:
        return results, []
    by_guid = {str(element.GlobalId): element for element in elements if str(element.GlobalId) in reasons}
    step_ids = {element.id() for element in by_guid.values()}
    for result in results:
        for step_id, component in zip(result.step_ids, result.components, strict=True):
            if step_id in step_ids:
                shutil.rmtree(out_dir / component.files.model_dir, ignore_errors=True)
    _log.info("%d element(s) left out once converted (context massing, small fittings)", len(by_guid))
    skipped = [skipped_entry(element, reasons[guid]) for guid, element in by_guid.items()]
    return [without_elements(result, step_ids, set(reasons)) for result in results], skipped
