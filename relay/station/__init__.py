"""The relay's own state and wiring: the fleet as it knows it, the hub, and what every client is told."""
