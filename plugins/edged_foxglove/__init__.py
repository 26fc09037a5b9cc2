"""Foxglove output: a live Foxglove WebSocket server with the MCAP recording's channels (issue 35)."""
