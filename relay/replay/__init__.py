"""Station sessions recorded as MCAP, for review and replay (issue #34)."""
