"""What the panels are built with: their context and the frame they are given
(:mod:`~app.ui.context`), display units and labels (:mod:`~app.ui.display`), GUI text
(:mod:`~app.ui.text`), uPlot charts (:mod:`~app.ui.charts`), the help folders
(:mod:`~app.ui.help`), the page's script (:mod:`~app.ui.page_script`), dialogs
(:mod:`~app.ui.dialogs`), the upload guard (:mod:`~app.ui.upload_guard`) and icons set while
running (:mod:`~app.ui.icons`)."""
