"""`edged demo`: the built-in simulated vessel, read by the daemon's real inputs.

The simulator (edged_sim) plays a vessel in real time onto a python-can `virtual` bus
and an NMEA 0183 UDP socket on 127.0.0.1; the daemon reads both through its own CAN
and NMEA inputs, runs every installed estimator, records to MCAP in `--record-dir`
and publishes over Zenoh with the safe defaults (this machine only). Nothing is sent
beyond loopback.

On a terminal it shows a live dashboard (`dashboard` lays out `tables` and `panels`,
`live` redraws it each second from what `feed` takes off the router); without one it
prints plain status lines. Beside the
recording it writes the vessel's truth (`truth`), so that `edged score` and `edged
plot --truth` can judge the run.
"""
