"""Studies built on the library, kept out of its core: the work-precision study
(:mod:`~coexist.studies.accuracy`) and its figure (:mod:`~coexist.studies.plotting`), and the
independent reference for wrinkled membranes (:mod:`~coexist.studies.wrinkled_reference`: the relaxed
energy of the discretised membrane minimised with IPOPT)."""
