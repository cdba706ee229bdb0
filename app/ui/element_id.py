"""The id viser gives a GUI element, read in one place.

viser (1.1) names every GUI element of the page, and every message about it, by an id it makes
when the element is added, and has no public accessor for it: only the handle's private
``_impl.uuid``. The studio needs it where it meets the page or viser's messages beside the
handle's API: the page's script finds the tab reporter and the Observed % slider by it
(:mod:`app.ui.page_script`), and the upload guard recognises its button's file transfers
(:mod:`app.ui.upload_guard`). Should viser rename it, this function is the one place to mend.
"""

from __future__ import annotations

import viser


def element_id(handle: viser.GuiButtonHandle | viser.GuiButtonGroupHandle
               | viser.GuiUploadButtonHandle | viser.GuiSliderHandle) -> str:  # fmt: skip
    """The id of ``handle``'s element in the page and in viser's messages."""
    return handle._impl.uuid
