"""xr-relay: bridges a ROS 2 robot fleet to a WebXR operator station over one WebSocket."""

__version__ = "0.1.0"
SERVER_NAME = "xr-relay"
