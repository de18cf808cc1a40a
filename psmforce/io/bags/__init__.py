"""ROS bags (ROS 2 sqlite3 / MCAP, ROS 1) and CSV exports into the recording layout.

``sample_from_messages`` (:mod:`.messages`) turns the latest arm, jaw and HEX10 messages into
the streaming estimator's sample: the one decoding that ``convert``, ``replay`` and ``serve``
share. ``convert_bag`` reads the dVRK CRTK topics with the pure-Python ``rosbags`` reader (no ROS
installation), puts every stream on one clock and writes one recording CSV
(:mod:`psmforce.io.recording`). ``summary_line`` condenses its report into one line for the
command line. ``load_column_map`` / ``convert_csv`` bring CSV exports with other column names
into the same layout. The rules (topics, timestamps, resampling, gaps) are in
``docs/data_format.md`` and in the docstrings of :mod:`.conversion` and :mod:`.resampling`.
"""

from psmforce.io.bags.column_map import check_column_map, convert_csv, load_column_map
from psmforce.io.bags.conversion import convert_bag, summary_line
from psmforce.io.bags.messages import (ROS2_TYPESTORE, SAMPLE_COLUMNS, MessageError,
                                     sample_from_messages)
from psmforce.io.bags.reading import STREAMS, BagError, default_topics

__all__ = ["BagError", "MessageError", "ROS2_TYPESTORE", "SAMPLE_COLUMNS", "STREAMS",
           "check_column_map", "convert_bag", "convert_csv", "default_topics", "load_column_map",
           "sample_from_messages", "summary_line"]
