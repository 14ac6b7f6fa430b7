"""The world the robots move in: their events, poses, maps, scans and where an operator should stand."""
