"""Moved to `edged.bytesinks` (a plugin may not import another): kept only until the
bridge outputs written beside it import it from there."""
from edged.bytesinks import *  # noqa: F401,F403
