"""NMEA 0183 input for edged: serial, TCP, UDP and file transports, framing, decoding.

The layers are separate so that live input and replay share everything but the
transport: `lines` turns bytes into checked sentences (`framer` adds the counting),
`logfile` reads a log for replay, `timeofday` stamps replayed lines with the log's time, `decoder` turns raw records into canonical measurements
(and is all that a replay of an MCAP recording needs), `link` keeps a live transport
open (watchdog, reconnect with backoff), and `plugin` ties them to the edged contract.
"""

from .config import Nmea0183Config
from .decoder import Nmea0183Decoder
from .plugin import Nmea0183Input

__all__ = ["Nmea0183Config", "Nmea0183Decoder", "Nmea0183Input"]
