"""Studies built on the library, kept out of its core: the work-precision study
(:mod:`~coexist.studies.accuracy`) and its figure (:mod:`~coexist.studies.plotting`)."""
