"""What happens in time: one inference of the Infer tab as the studio shows it
(:mod:`~app.live.inference`, the recognition over a whole movement:
:mod:`~app.live.recognition_curve`), the live stream it observes (:mod:`~app.live.stream`), a
take from the Record button to a demonstration (:mod:`~app.live.take_controller`,
:mod:`~app.live.recorder`, :mod:`~app.live.takes`), the replay of a prediction
(:mod:`~app.live.replay`) and the partner's head (:mod:`~app.live.head`). Small controllers with
explicit states, tested without a browser; no viser."""
