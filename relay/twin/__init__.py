"""The digital twin: glTF scenes of the facility, of occupancy maps and of robots, and their frames."""
