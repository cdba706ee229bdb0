"""The studio's files: the workspace folder (:mod:`~app.io.workspace`) and its index
``studio.json`` (:mod:`~app.io.workspace_index`, the checks it keeps: :mod:`~app.io.demo_checks`),
its trash (:mod:`~app.io.trash`), the model and workspace files that leave and enter the studio
(:mod:`~app.io.exchange`), one's own recordings imported (:mod:`~app.io.dataset_import`), and the
port checks made before the server starts (:mod:`~app.io.net`). No viser; imports nothing else
of the studio."""
