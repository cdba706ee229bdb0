"""The studio's state: the workspace as it is on disk (:mod:`~app.core.store`), the model learned
from it in the background (:mod:`~app.core.learner`, its fits kept by :mod:`~app.core.fits`),
what the user looks at (:mod:`~app.core.view_state`), and one immutable picture of the three
per frame (:mod:`~app.core.snapshot`), held together by :mod:`~app.core.session`. No viser."""
