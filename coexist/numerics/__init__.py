"""Physics-free machinery: the vectorised DOP853 integrator (:mod:`~coexist.numerics.dop853`), the
CasADi-to-numpy code generator (:mod:`~coexist.numerics.codegen`), compiled CasADi functions and their
cache (:mod:`~coexist.numerics.compiled`), splines (:mod:`~coexist.numerics.splines`) and root finding
(:mod:`~coexist.numerics.roots`). Each has its own direct tests; none knows about membranes."""
