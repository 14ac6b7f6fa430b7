"""Cameras to clients: lens models, JPEG and H.264 encoding, streams and their pacing."""
