"""Live force estimation: the node's logic (:mod:`.node`), its ROS 2 messages as CDR
(:mod:`.cdr`) and as DDS types (:mod:`.dds`), ``psmforce replay`` (:mod:`.replay`, MCAP and a
Foxglove view: :mod:`.view`), ``psmforce serve`` (:mod:`.serve`) and a simulated robot
(:mod:`.robot`); the commands: :mod:`.commands`. ``docs/live.md`` is the guide.

Only :mod:`.dds` and :mod:`.serve` need ``cyclonedds``, :mod:`.view` ``mcap`` and
``foxglove-sdk`` (the extra ``psmforce[ros]``); they are imported when used.
"""
