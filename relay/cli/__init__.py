"""The xr-relay command: run options, the relay's start-up, and `xr-relay record`."""
