"""Recordings in and out: the recording layout every command reads (:mod:`.recording`) and ROS
bags and CSV exports into it (:mod:`.bags`)."""
