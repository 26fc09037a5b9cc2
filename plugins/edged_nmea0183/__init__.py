"""NMEA 0183 input for edged: serial, TCP, UDP and file transports, framing, decoding.

The layers are separate so that live input and replay share everything but the
transport: `lines` turns bytes into checked sentences (`framer` adds the counting),
`logfile` reads a log for replay, `timeofday` stamps replayed lines with the log's time, `decoder` turns raw records into canonical measurements
(and is all that a replay of an MCAP recording needs), `link` keeps a live transport
open (watchdog, reconnect with backoff), `logs` is the log reader replay sniffs with,
and `plugin` ties them to the edged contract.
"""


# Nothing is imported here: `edged replay` loads the light log reader `logs.NMEA0183`
# to sniff any file, and a CAN log must not import the NMEA 0183 decoder (and numpy)
# for it. Import the modules themselves (`edged_nmea0183.plugin`, `.decoder`).

#: The protocol of this input's raw records (`RawRecord.protocol`): a constant here,
#: where the light log reader (`logs`) and the reading stack (`logfile`, `plugin`)
#: both take it without importing each other.
PROTOCOL = "nmea0183"
