"""The ``psmforce`` command line (:mod:`.main`): the offline commands (:mod:`.offline`), the live
ones (:mod:`.live`), the checks every option passes before the work (:mod:`.options`), the guard
that keeps outputs off inputs (:mod:`.guards`) and the demo (:mod:`.demo`)."""
