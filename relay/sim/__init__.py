"""Pure building blocks of the simulated fleet: floor plan, planner, kinematics, path following, hazards."""
