"""NMEA 2000 output: the fused values as PGNs on a CAN bus or through a gateway (issue 35)."""
