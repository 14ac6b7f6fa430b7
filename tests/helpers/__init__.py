"""What several test modules use, in one place: a test module imports helpers from here (or fixtures from a
conftest), never from another test module, so that running one test file never runs or imports another's tests.

browser: a page of the operator station in Chromium (Client), the relay under test (Station), waits and timings.
xr: driving IWER's emulated headset (controllers, hands, gaze) and entering VR.
cli: the relay as a user starts it (``python -m relay``), its URL and token from its first line.
hub: a transport that records what the hub sends a client, and can stall like a peer that stopped reading.
ros: a robot on the other side of DDS (tests/ros_peer.py in its own process) and the lines it prints.
"""
