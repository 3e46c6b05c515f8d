"""Studies built on the library, kept out of its core: the work-precision study
(:mod:`~coexist.studies.accuracy`) and its figure (:mod:`~coexist.studies.plotting`), and wrinkled
membranes ahead of the vectorised shooting: the independent reference
(:mod:`~coexist.studies.wrinkled_reference`: the relaxed energy of the discretised membrane minimised
with IPOPT) and the shooting equations of hoop-wrinkled segments
(:mod:`~coexist.studies.wrinkled_shooting`: taut and wrinkled segments with switching, one state at a
time with scipy's DOP853)."""
