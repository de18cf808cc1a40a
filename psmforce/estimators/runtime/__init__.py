"""A trained model at run time: one sample at a time (:mod:`.streaming`, its step backends
:mod:`.steppers` and post-filter :mod:`.postfilter`) and ONNX export (:mod:`.export`)."""
