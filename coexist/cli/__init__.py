"""The ``coexist`` command line (installed as :mod:`coexist.cli`): a thin click layer over the library."""
