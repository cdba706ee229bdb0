"""The 3D view: :class:`app.scene.scene_view.SceneView` (what is drawn and how it looks), the
robot and its table (:mod:`~app.scene.robot`), its arm dragged by the hand
(:mod:`~app.scene.arm`), the partner (:mod:`~app.scene.partner`), the workspace's
demonstrations and priors (:mod:`~app.scene.workspace_layer`), the Infer tab's inference
(:mod:`~app.scene.inference_layer`), Teach's start pose (:mod:`~app.scene.start_marker`) and
the camera (:mod:`~app.scene.camera`, its buttons :mod:`~app.scene.camera_buttons`)."""
