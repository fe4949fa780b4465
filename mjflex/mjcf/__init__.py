"""Elements in an MJCF file or an ``MjSpec``: the first stage of an element's path.

How an element is written (:mod:`.schema`: a text record ``mjflex:E`` with sites ``E/a``, ``E/b``,
or an instance of the engine plugin ``mjflex.flexure``; end stops, :mod:`.stops`), adding and
removing elements in a spec (:mod:`.build`), reading, editing and writing the elements of a spec
(:mod:`.elements`), converting them between the two forms and composing specs (:mod:`.convert`),
replacing a body's joints by an element (:mod:`.joints`, :mod:`.coordinates`, :mod:`.keyframes`), and
the spec helpers they share (:mod:`.spec`). Nothing here reads a compiled model's elements: that is
:mod:`mjflex.runtime`. Imports :mod:`mjflex.core` and the C library's bindings
(:mod:`mjflex.native.library`) only.
"""

from .build import FlexureHandle, add_flexure, add_flexure_in_body_frame, remove_flexure
from .convert import attach, convert_model, copy_spec, spec_xml
from .elements import edit_elements
from .joints import Replacement
from .notices import LikelyMistakeWarning
from .schema import FlexureRecord
from .spec import reference_body_poses
from .stops import Stops

__all__ = [
    "FlexureHandle",
    "FlexureRecord",
    "LikelyMistakeWarning",
    "Replacement",
    "Stops",
    "add_flexure",
    "add_flexure_in_body_frame",
    "attach",
    "convert_model",
    "copy_spec",
    "edit_elements",
    "reference_body_poses",
    "remove_flexure",
    "spec_xml",
]
