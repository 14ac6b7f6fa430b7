"""``xr-relay watchdog``: a robot-side stop that works whatever happens to the relay (relay.watchdog.rules)."""
