"""The real-robot path: replay logged runs with any geometry, calibrate, evaluate, hold out
(:mod:`~umbmark.realrobot.replay`, results in :mod:`~umbmark.realrobot.results`); measure the
return pose with a tape (:mod:`~umbmark.realrobot.measure`); the field procedure
(:mod:`~umbmark.realrobot.guide`)."""

__all__: list[str] = []
