"""Signal K output: the fused values as Signal K deltas over TCP or UDP (issue 35)."""
