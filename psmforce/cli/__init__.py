"""The ``psmforce`` command line (:mod:`.main`): the offline commands (:mod:`.offline`), the live
ones (:mod:`.live`), the demo (:mod:`.demo`) and the output guard (:mod:`.guards`)."""
