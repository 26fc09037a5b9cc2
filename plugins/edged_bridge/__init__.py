"""Moved to the core (edged.bridgeoutput, edged.bridgeview, edged.bytesinks)."""
