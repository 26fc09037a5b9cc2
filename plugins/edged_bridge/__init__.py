"""What the bridge outputs share: the fused values as the ship's instruments take them.

The NMEA 0183, NMEA 2000 and Signal K outputs (issue 35) each send the same few
values (STW, current, heading, rate of turn, the drafts) in their own format. What
they have in common lives here, once:

- `view.BridgeView`: the latest estimate of each role (stw, manoeuvre, draft) and
  each value in SI units, or None where it must not go out as a number (stale,
  converging, missing, too old, a mark that is out);
- `base.BridgeOutput`: an output that takes only those estimates and sends each of
  its messages, at the message's own rate of data time, when an estimate it is made
  of arrives;
- `transports`: the byte links a text protocol goes out on (UDP unicast or
  broadcast, a TCP server for several clients, a serial port).
"""
